"""Gyrostats, bodies with wheels (issue 28): the wheels' torque, the exact axisymmetric gyrostat, MuJoCo's wheels on
their hinges against both, the invariants, and the refusals of wheels xcheck does not model."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from xcheck import rotations as rot
from xcheck.engines.mujoco import simulate
from xcheck.fields import ConstantTorque, SumTorque, WheelsTorque
from xcheck.fields.kernel import pulse
from xcheck.integrators import integrate
from xcheck.metrics import invariant_changes
from xcheck.models import ModelError, initial_state, load_body
from xcheck.paths import BUNDLED_MODELS
from xcheck.reference import dop853, exact_gyrostat, exact_reference, exact_why_not
from xcheck.scenario import ScenarioError, resolve_scenario
from xcheck.study.context import run_context, scenario_reference

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

GYROSTAT = BUNDLED_MODELS / "gyrostat.xml"
TUMBLER = BUNDLED_MODELS / "tumbler_wheels.xml"


def test_the_pulse_integral_is_its_quadrature():
    """Truth: scipy's quad of the pulse's value. Zero before t0, u (t1 - t0) / 2 after t1, value and slope
    continuous at both ends."""
    u, t0, t1 = 0.2, 0.5, 1.75
    for t in (0.0, 0.5, 0.9, 1.3, 1.75, 3.0):
        want, _ = quad(lambda s: pulse(u, t0, t1, s)[1], 0.0, t, points=[t0, t1], epsabs=1e-15)
        assert pulse(u, t0, t1, t)[0] == pytest.approx(want, abs=1e-14)
    assert pulse(u, t0, t1, 5.0) == (pytest.approx(u * (t1 - t0) / 2, rel=1e-15), 0.0)
    for edge in (t0, t1):
        assert abs(pulse(u, t0, t1, edge + 1e-7)[1]) < 1e-11  # sin^2 leaves zero quadratically


def test_the_wheels_torque_is_the_gyrostat_term():
    """Truth: the hand-written -w x h(t) - h'(t) at a time inside a pulse, h = h0 + a * (its integral)."""
    a = np.array([0.0, 0.6, 0.8])
    tq = WheelsTorque([0.1, -0.2, 0.3], [(a, 0.05, 0.0, 2.0)])
    t, w = 0.7, np.array([0.4, -0.1, 0.25])
    integral, value = pulse(0.05, 0.0, 2.0, t)
    h = np.array([0.1, -0.2, 0.3]) + integral * a
    np.testing.assert_allclose(tq(t, [1.0, 0.0, 0.0, 0.0], w), -np.cross(w, h) - value * a, rtol=0, atol=1e-16)
    np.testing.assert_allclose(tq.internal_momentum([t])[0], h, rtol=0, atol=1e-16)
    # composed with a constant torque, in one compiled sum: the terms added
    both = SumTorque([tq, ConstantTorque([1e-3, 0.0, -2e-3])])
    np.testing.assert_allclose(both(t, [1, 0, 0, 0], w), tq(t, [1, 0, 0, 0], w) + [1e-3, 0.0, -2e-3], rtol=0, atol=1e-17)
    assert both.conserves_momentum is False and both.momentum_axis() is None


@pytest.mark.parametrize("seed", range(3))
def test_the_exact_gyrostat_matches_dop853(seed):
    """Truth: DOP853 at rtol 1e-13 on the gyrostat's equation (the body with the wheels' torque), for an
    inertia symmetric about the wheel's axis, in a rotated body frame."""
    rng = np.random.default_rng(seed)
    R = rot.quat_to_dcm(rot.quat_normalize(rng.normal(size=4)))
    A, C = rng.uniform(0.2, 0.5), rng.uniform(0.1, 0.6)
    I = R @ np.diag([A, A, C]) @ R.T
    h = R @ np.array([0.0, 0.0, rng.uniform(-1.0, 1.0)])
    q0, w0 = rot.quat_normalize(rng.normal(size=4)), rng.normal(size=3)
    t = np.linspace(0.0, 10.0, 101)
    q, w = exact_gyrostat(I, q0, w0, t, h)
    qd, wd = dop853(I, q0, w0, t, torque=WheelsTorque(h))
    assert np.max(rot.attitude_error(q, qd)) < 1e-11
    np.testing.assert_allclose(w, wd, rtol=0, atol=1e-11)


def test_an_asymmetric_gyrostat_has_no_closed_form():
    why = exact_why_not(np.diag([1.0, 2.0, 3.0]), WheelsTorque([0.0, 0.0, 0.5]))
    assert "not symmetric about the wheels' momentum" in why
    assert "a motor changes the wheels' momentum" in exact_why_not(np.eye(3), WheelsTorque(
        [0, 0, 1.0], [((0, 0, 1.0), 0.1, 0.0, 1.0)]))


def test_the_gyrostat_model_is_its_hand_computed_inertia():
    """Truth: the MJCF's numbers. The bus diag(0.3, 0.3, 0.2) and the wheel diag(0.006, 0.006, 0.01) at one
    centre: the whole body less the wheel's axial moment is diag(0.306, 0.306, 0.2); h = 0.01 (0.5 + 50)."""
    body = load_body(GYROSTAT)
    np.testing.assert_allclose(body.inertia, np.diag([0.306, 0.306, 0.2]), rtol=0, atol=1e-15)
    (wheel,) = body.wheels
    assert wheel.axis == (0.0, 0.0, 1.0) and wheel.moment == pytest.approx(0.01) and wheel.speed == 50.0
    state = initial_state(GYROSTAT)
    assert state.wheel_speeds == (50.0,)
    np.testing.assert_allclose(body.own_torque(state.omega0, state.wheel_speeds).h0, [0, 0, 0.01 * 50.5], atol=1e-15)


def test_three_wheels_off_the_centre_are_a_composite_body():
    """Truth: the parallel-axis theorem by hand. A bus diag(1, 2, 3) (2 kg) at the origin and three wheels of
    0.3 kg 0.2 m out along their own axes; less each wheel's axial moment (0.004) about its axis."""
    body = load_body(TUMBLER)
    positions = 0.2 * np.eye(3)
    com = 0.3 * positions.sum(axis=0) / 2.9
    want = np.diag([1.0, 2.0, 3.0]) + 2.0 * (com @ com * np.eye(3) - np.outer(com, com))
    for k in range(3):
        d = positions[k] - com
        own = np.full(3, 0.0025)
        own[k] = 0.004
        want += np.diag(own) + 0.3 * (d @ d * np.eye(3) - np.outer(d, d)) - 0.004 * np.outer(np.eye(3)[k], np.eye(3)[k])
    np.testing.assert_allclose(body.inertia, want, rtol=0, atol=1e-14)
    assert [w.pulse for w in body.wheels] == [(0.2, 0.0, 1.0), None, None]


def test_mujoco_turns_the_wheel_as_the_exact_gyrostat_does():
    """Truth: the closed form. MuJoCo's RK4 on the bus and its wheel (a hinge) reaches it at fourth order; its
    wheel keeps the speed the reference's momentum gives."""
    body = load_body(GYROSTAT)
    q0, w0 = rot.quat_normalize([0.9, 0.1, -0.3, 0.2]), np.array([0.3, -0.2, 0.5])
    torque = body.own_torque(w0)
    errors = []
    for dt in (1 / 64, 1 / 128):
        run = simulate(GYROSTAT, integrator="rk4", q0=q0, omega0=w0, dt=dt, duration=5.0)
        q, w = exact_reference(body.inertia, q0, w0, run.t, torque)
        errors.append(np.max(rot.attitude_error(run.q, q)))
        speeds = torque.wheel_speeds(run.t, w)
        assert np.max(np.abs(run.extras["wheel_speeds"] - speeds)) < 1e-9
    assert errors[1] < 1e-9 and 14 < errors[0] / errors[1] < 18  # order 4: 2^4


def test_a_motor_spins_its_wheel_up_as_the_reference_does():
    """Truth: DOP853 at rtol 1e-13 on the gyrostat's equation; the x wheel's motor adds 0.2 * 1 / 2 = 0.1 N m s
    to its axial momentum over the first second (the pulse's integral), the body's momentum R (I w + h) is
    conserved, and MuJoCo's RK4 (the motor's ctrl set at every stage) agrees with both."""
    sc = resolve_scenario("tumbler-three-wheels")
    ctx, ref = run_context(sc), scenario_reference(sc)
    wheels = ctx.torque
    run = simulate(ctx.model_path, integrator="rk4", q0=ctx.q0, omega0=ctx.omega0, dt=1 / 256, duration=ctx.duration,
                   wheel_speeds=ctx.wheel_speeds)
    q, w, _ = ref.at(run.t)
    assert np.max(rot.attitude_error(run.q, q)) < 1e-9
    assert np.max(np.abs(run.extras["wheel_speeds"] - wheels.wheel_speeds(run.t, w))) < 1e-8
    p = [wheels.wheels[0][1] * (run.extras["wheel_speeds"][k, 0] + run.omega[k, 0]) for k in (0, -1)]
    assert p[1] - p[0] == pytest.approx(0.1, abs=1e-9)
    ours = integrate("lie-rkmk4", ctx.inertia, ctx.q0, ctx.omega0, dt=1 / 256, duration=ctx.duration, torque=wheels)
    drift = invariant_changes(ctx.inertia, ours, wheels)  # RK4 at 1/256 s: |L - L0| / |L0| 1.9e-12 measured
    assert abs(drift["momentum_change"]) < 1e-11 and drift["momentum_turn"] < 1e-11 and drift["energy_change"] is None


def test_free_wheels_conserve_the_bodys_energy_and_the_whole_momentum():
    """Truth: the gyrostat's invariants. With free wheels 1/2 w.I w (I less the axial moments) and R (I w + h) stay
    what they were, to round-off at a fine step."""
    body = load_body(TUMBLER)
    w0 = np.array([0.1, 0.5, 0.2])
    free = body.own_torque(w0, [0.0, 5.0, -3.0])
    free = WheelsTorque(free.h0, wheels=free.wheels)  # the same wheels, no motor
    run = integrate("lie-rkmk4", body.inertia, [1.0, 0, 0, 0], w0, dt=1 / 512, duration=10.0, torque=free)
    drift = invariant_changes(body.inertia, run, free)
    assert abs(drift["energy_change"]) < 1e-12 and abs(drift["momentum_change"]) < 1e-12 and drift["momentum_turn"] < 1e-12


WHEEL = """<mujoco><option gravity="0 0 0"><flag contact="disable"/></option>
<worldbody><body name="bus"><freejoint/><inertial pos="0 0 0" mass="4" diaginertia="0.3 0.3 0.2"/>
<body name="w" pos="{pos}"><joint name="spin" type="hinge" axis="0 0 1" {extra}/>
<inertial pos="{ipos}" mass="0.5" diaginertia="{dia}"/></body></body></worldbody>{tail}</mujoco>"""


@pytest.mark.parametrize("changes, match", [
    ({"dia": "0.006 0.007 0.01"}, "not axisymmetric about its hinge"),
    ({"ipos": "0.01 0 0"}, "its axis misses the wheel's centre of mass by 0.01 m"),
    ({"extra": 'damping="0.1"'}, "has damping 0.1: a wheel's axle is frictionless"),
    ({"tail": '<actuator><velocity joint="spin" kv="1"/></actuator>'},
     "allowed are only a <motor> .* on a wheel's hinge.* A velocity or position servo's result depends on its gains"),
    ({"tail": '<custom><numeric name="xcheck_pulse:nope" data="0.1 0 1"/></custom>'},
     "no motor named 'nope' on a wheel"),
    ({"tail": '<actuator><motor name="m" joint="spin" ctrllimited="true" ctrlrange="-0.05 0.05"/></actuator>'
              '<custom><numeric name="xcheck_pulse:m" data="0.1 0 1"/></custom>'},
     "its pulse needs 0.1 within its ctrlrange"),
    ({"tail": '<actuator><motor name="m" joint="spin"/></actuator><custom><numeric name="xcheck_pulse:m" '
              'data="0.1 2 1"/></custom>'}, 'expected data="peak t0 t1"'),
])
def test_wheels_xcheck_does_not_model_are_refused_by_name(tmp_path, changes, match):
    values = {"pos": "0 0 0", "extra": "", "ipos": "0 0 0", "dia": "0.006 0.006 0.01", "tail": "", **changes}
    path = tmp_path / "wheel.xml"
    path.write_text(WHEEL.format(**values))
    with pytest.raises(ModelError, match=f"{path}: .*{match}"):
        load_body(path)


def test_wheel_speeds_must_match_the_wheels(tmp_path):
    scenario = tmp_path / "s.toml"
    scenario.write_text(f'name = "s"\nmodel = "{GYROSTAT}"\nduration = 1.0\n[initial]\nquaternion = [1, 0, 0, 0]\n'
                        'angular_velocity = [0, 0, 1]\nwheel_speeds = [1.0, 2.0]\n[study]\nreference = "exact"\n')
    with pytest.raises(ScenarioError, match=r"s.toml: \[initial\] wheel_speeds: expected 1 finite speeds \[rad/s\] of at "
                                            r"most 1e\+05 \(one per wheel of .*gyrostat.xml: wheel\), got \[1.0, 2.0\]"):
        resolve_scenario(str(scenario))


def test_basilisk_turns_free_wheels_as_the_exact_gyrostat_does():
    """Truth: the closed form. Basilisk's ReactionWheelStateEffector (balanced wheels, the hub's inertia the whole
    body's) under its RK4 reaches it at fourth order, its wheel's speed the reference's."""
    pytest.importorskip("Basilisk", reason="Basilisk (PyPI bsk, the 'basilisk' extra) is not installed here")
    from xcheck.engines.basilisk import simulate as basilisk

    body = load_body(GYROSTAT)
    q0, w0 = rot.quat_normalize([0.9, 0.1, -0.3, 0.2]), np.array([0.3, -0.2, 0.5])
    torque = body.own_torque(w0)
    errors = []
    for dt in (1 / 64, 1 / 128):
        run = basilisk(body.inertia, integrator="rk4", q0=q0, omega0=w0, dt=dt, duration=5.0, torque=torque)
        q, w = exact_reference(body.inertia, q0, w0, run.t, torque)
        errors.append(np.max(rot.attitude_error(run.q, q)))
        assert np.max(np.abs(run.extras["wheel_speeds"] - torque.wheel_speeds(run.t, w))) < 1e-9
    assert errors[1] < 1e-9 and 14 < errors[0] / errors[1] < 18  # order 4: 2^4


def test_basilisk_holds_a_motors_pulse_over_each_step():
    """Truth: DOP853. Basilisk reads a wheel's motor command (rwMotorCmdInMsg) once per step: the pulse written at
    each step's midpoint and held is a midpoint rule, order 2 in the attitude and the wheels' speeds, as declared;
    its recorded speeds are the wheels' at each step's end (the effector writes them before the hub integrates)."""
    pytest.importorskip("Basilisk", reason="Basilisk (PyPI bsk, the 'basilisk' extra) is not installed here")
    from xcheck.runners import RUNNERS

    sc = resolve_scenario("tumbler-three-wheels")
    ctx, ref = run_context(sc), scenario_reference(sc)
    assert RUNNERS["basilisk-rk4"].order_for(sc.torque, sc.model)[0] == 2
    att, speed = [], []
    for dt in (1 / 64, 1 / 128):
        run = RUNNERS["basilisk-rk4"].run(ctx, dt)
        q, w, _ = ref.at(run.t)
        att.append(np.max(rot.attitude_error(run.q, q)))
        speed.append(np.max(np.abs(run.extras["wheel_speeds"] - ctx.torque.wheel_speeds(run.t, w))))
    assert 3.5 < att[0] / att[1] < 4.5 and 3.5 < speed[0] / speed[1] < 4.5 and speed[1] < 1e-3


def test_a_list_of_torques_is_their_sum_at_every_state(tmp_path):
    """Truth: each term built alone from a scenario of its own. [[torque]] sums them in one compiled call, and the
    model's own (the wheels') is added to them; the gravity gradient pulls on the whole mass, wheels included."""
    sc = resolve_scenario("rax1-momentum-bias")
    ctx = run_context(sc)
    body = load_body(sc.model)
    parts = []
    for term in sc.torque:
        one = tmp_path / f"{term['kind']}.toml"
        one.write_text(sc.path.read_text().split("\n[[torque]]\n")[0].replace('"../', f'"{sc.path.parent}/../') +
                       "[torque]\n" + "".join(f"{k} = \"{v}\"\n" for k, v in term.items()) +
                       '[study]\nreference = "dop853"\nmethods = ["lie-rkmk4"]\n')
        parts.append(run_context(resolve_scenario(str(one))).torque)
    wheels = body.own_torque(sc.omega0, sc.wheel_speeds)  # in each scenario: once in the sum of the two
    rng = np.random.default_rng(5)
    for _ in range(3):
        t, q, w = rng.uniform(0, 10), rot.quat_normalize(rng.normal(size=4)), rng.normal(size=3)
        want = parts[0](t, q, w) + parts[1](t, q, w) - wheels(t, q, w)
        np.testing.assert_allclose(ctx.torque(t, q, w), want, rtol=1e-12, atol=1e-22)
    gg = next(term for term in ctx.torque.terms if type(term).__name__ == "GravityGradientTorque")
    np.testing.assert_allclose(gg.P[:9], (body.inertia + 1.6e-5 * np.diag([0, 0, 1.0])).ravel(), rtol=0, atol=1e-15)


def test_a_sweep_of_wheel_momentum_and_dipole_passes_in_every_cell(tmp_path):
    """Truth: DOP853 per cell. Cells of a gyrostat whose wheels' momentum differs (their speeds, their body rate)
    never share a batch: sharing one gave our methods the first cell's momentum (0.1 rad off, MuJoCo right)."""
    from xcheck.cli import main

    spec = tmp_path / "s.toml"
    spec.write_text('base = "rax1-momentum-bias"\nmethods = ["formulation-2", "lie-rkmk4", "mujoco-rk4"]\n'
                    '[axes.wheel_speed_scale]\nvalues = [0.001, 0.01, 0.1, 1.0]\n[axes.rate_scale]\nvalues = [1.0, 2.0]\n'
                    '[axes.dt]\nvalues = [0.0625, 0.03125, 0.015625]\n')
    assert main(["sweep", str(spec), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0


def test_a_sweep_switches_torque_terms_on_and_off(tmp_path):
    from xcheck.sweep.spec import apply_cell

    sc = resolve_scenario("rax1-momentum-bias")
    assert apply_cell(sc, {"torques": ["gravity-gradient"]}).torque == {"kind": "gravity-gradient"}
    assert apply_cell(sc, {"torques": []}).torque is None
    assert apply_cell(sc, {"torques": ["magnetic", "gravity-gradient"]}).torque == sc.torque
    assert apply_cell(sc, {"wheel_speed_scale": 0.5}).wheel_speeds == (314.15,)


def test_the_full_report_draws_how_the_wheels_stiffen_the_attitude():
    """A body with wheels gets the figure of its wheels' axis with the wheels and with them stopped; a body without
    gets none. The curves are the study's (issue 38: the figure integrates nothing). Truth for the axisymmetric
    gyrostat: with the wheel its symmetry axis cones about the fixed momentum H at a constant angle, so it never turns
    more than twice that angle from its start."""
    from xcheck.report.plots import _wheels_stiffness
    from xcheck.study import run_study

    st = run_study(resolve_scenario("gyrostat-axisymmetric"), methods=["lie-rkmk4"], workers=1, timing=False)
    (file, caption, png), = _wheels_stiffness(st.data, "g")
    assert file == "g-wheels-stiffness.png" and png.startswith(b"\x89PNG") and "stopped" in caption
    rigid = run_study(resolve_scenario("tumbler-intermediate-axis"), methods=["lie-rkmk4"], quick=True, workers=1,
                      timing=False)
    assert _wheels_stiffness(rigid.data, "t") == []
    body, sc = load_body(GYROSTAT), resolve_scenario("gyrostat-axisymmetric")
    torque = body.own_torque(sc.omega0, sc.wheel_speeds)
    H = body.inertia @ sc.omega0 + torque.h0
    cone = np.arccos(abs(H @ torque.h0) / (np.linalg.norm(H) * np.linalg.norm(torque.h0)))
    run = integrate("lie-rkmk4", body.inertia, sc.q0, sc.omega0, dt=1 / 512, duration=10.0, torque=torque)
    e = torque.h0 / np.linalg.norm(torque.h0)
    turned = np.arccos(np.clip(rot.quat_rotate(run.q, e) @ rot.quat_rotate(run.q[0], e), -1, 1))
    assert np.max(turned) <= 2 * cone + 1e-9 and np.max(turned) > 1.9 * cone  # it reaches the far side
    drawn = np.radians(st.data["wheels_stiffness"]["angle_deg"]["with the wheels"])  # sampled: near the far side
    assert np.max(drawn) <= 2 * cone + 1e-9 and np.max(drawn) > 1.9 * cone
