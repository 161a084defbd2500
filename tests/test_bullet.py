"""PyBullet as an engine (issue 40): the conversions at its boundary, both ways and against Bullet's own reading of
a body; its two paths' first order against the exact answer; what each path is (MuJoCo's semi-implicit Euler and its
implicit gyroscopic step, to round-off); what its defaults cost. Skipped, saying so, when PyBullet (the extra
``engines``) is not installed."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="PyBullet is not installed (pip install 'xcheck[engines]')")
if not __import__("xcheck.engines", fromlist=["available"]).available("pybullet"):
    pytest.skip("PyBullet is installed but left out here ($XCHECK_WITHOUT names it)", allow_module_level=True)

from xcheck import rotations as rot  # noqa: E402
from xcheck.body import principal_axes  # noqa: E402
from xcheck.engines.bullet import (  # noqa: E402
    DEFAULT_ANGULAR_DAMPING, _pybullet, clamped_turn, from_bullet, simulate, to_bullet)
from xcheck.metrics import observed_order, world_momentum  # noqa: E402
from xcheck.reference import exact_torque_free  # noqa: E402
from xcheck.runners import RUNNERS  # noqa: E402
from xcheck.scenario import resolve_scenario  # noqa: E402
from xcheck.study.context import run_context  # noqa: E402

I = np.array([[1.5, 0.1, 0.0], [0.1, 2.0, -0.05], [0.0, -0.05, 3.0]])
Q0 = np.array([0.7071067811865476, 0.7071067811865476, 0.0, 0.0])
W0 = np.array([0.02, 2.0, 0.03])


def test_the_conversions_round_trip_both_ways():
    rng = np.random.default_rng(40)
    q = rng.standard_normal((100, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.standard_normal((100, 3))
    _, V = principal_axes(I)
    orn, ww = to_bullet(q, w, V)
    back_q, back_w = from_bullet(orn, ww, V)
    np.testing.assert_allclose(np.abs(np.sum(back_q * q, axis=1)), 1.0, atol=1e-15)
    np.testing.assert_allclose(back_w, w, atol=1e-14)
    again = to_bullet(back_q, back_w, V)
    np.testing.assert_allclose(np.abs(np.sum(again[0] * orn, axis=1)), 1.0, atol=1e-15)
    np.testing.assert_allclose(again[1], ww, atol=1e-14)


def test_bullet_reads_the_state_as_xcheck_writes_it():
    """Truth: Bullet itself. Its world angular momentum of the body we give it (``getDynamicsInfo``'s principal
    moments about its inertial frame, its world angular velocity) is ours, R I w, to rounding; and after one short step
    of an isotropic body spinning about world z at 1 rad/s, its orientation has turned by 1e-3 rad about world z
    (Bullet's quaternion scalar last, body -> world)."""
    p = _pybullet()
    client = p.connect(p.DIRECT)
    try:
        _, V = principal_axes(I)
        orn, ww = to_bullet(Q0, W0, V)
        body = p.createMultiBody(baseMass=1.0, baseCollisionShapeIndex=-1, baseOrientation=orn.tolist(),
                                 physicsClientId=client)
        moments = np.linalg.eigvalsh(I)
        p.changeDynamics(body, -1, localInertiaDiagonal=moments.tolist(), angularDamping=0.0, physicsClientId=client)
        p.resetBaseVelocity(body, [0, 0, 0], ww.tolist(), physicsClientId=client)
        got_orn = np.array(p.getBasePositionAndOrientation(body, physicsClientId=client)[1])
        got_w = np.array(p.getBaseVelocity(body, physicsClientId=client)[1])
        q_p = np.concatenate([got_orn[3:], got_orn[:3]])
        L_bullet = rot.quat_to_dcm(q_p) @ (moments * (rot.quat_to_dcm(q_p).T @ got_w))
        np.testing.assert_allclose(L_bullet, world_momentum(I, Q0, W0), rtol=1e-13, atol=1e-15)
        iso = p.createMultiBody(baseMass=1.0, baseCollisionShapeIndex=-1, physicsClientId=client)
        p.changeDynamics(iso, -1, localInertiaDiagonal=[1, 1, 1], angularDamping=0.0, physicsClientId=client)
        p.resetBaseVelocity(iso, [0, 0, 0], [0, 0, 1.0], physicsClientId=client)
        p.setPhysicsEngineParameter(fixedTimeStep=1e-3, physicsClientId=client)
        p.setGravity(0, 0, 0, physicsClientId=client)
        p.stepSimulation(physicsClientId=client)
        x, y, z, w = p.getBasePositionAndOrientation(iso, physicsClientId=client)[1]
        np.testing.assert_allclose([w, x, y, z], [np.cos(5e-4), 0, 0, np.sin(5e-4)], atol=1e-12)
    finally:
        p.disconnect(physicsClientId=client)


@pytest.mark.parametrize("path", ["multibody", "maximal"])
def test_each_path_is_first_order_against_the_exact_answer(path):
    """Truth: the torque-free closed form on a body with products of inertia. Both paths step semi-implicitly: order
    1.00 +- 0.05 from 1/100 to 1/800 s."""
    dts = [0.01, 0.005, 0.0025, 0.00125]
    errors = []
    for dt in dts:
        tr = simulate(I, path=path, q0=Q0, omega0=W0, dt=dt, duration=5.0)
        q, _ = exact_torque_free(I, Q0, W0, tr.t)
        errors.append(float(rot.attitude_error(tr.q[-1], q[-1])))
    assert observed_order(dts, errors).order == pytest.approx(1.0, abs=0.05), errors


@pytest.mark.parametrize("scenario", ["tumbler-intermediate-axis", "boxes-complex", "gyroscope-nonsingular"])
def test_bullets_two_paths_are_mujocos_euler_and_implicit_steps(scenario):
    """Truth: MuJoCo's integrators (4.0). Bullet's btMultiBody step is MuJoCo's semi-implicit Euler, and its
    btRigidBody step with the implicit gyroscopic term is MuJoCo's implicitfast, each to 1e-10 rad over the run at the
    scenario's middle quick step; the two differ from each other by 1e-5 to 1e-1 rad."""
    sc = resolve_scenario(scenario)
    ctx = run_context(sc)
    dt = sc.quick_steps[2]
    runs = {m: RUNNERS[m].run(ctx, dt) for m in ("pybullet-multibody", "pybullet-maximal", "mujoco-euler",
                                                  "mujoco-implicitfast")}
    assert rot.attitude_error(runs["pybullet-multibody"].q, runs["mujoco-euler"].q).max() < 1e-10
    assert rot.attitude_error(runs["pybullet-maximal"].q, runs["mujoco-implicitfast"].q).max() < 1e-10
    assert rot.attitude_error(runs["pybullet-multibody"].q, runs["pybullet-maximal"].q).max() > 1e-5


def test_the_multibodys_default_damping_takes_a_third_of_the_momentum():
    """Finding: the boxes benchmark's box spun near its intermediate axis (its complex case), 2 s at 1e-3 s: with
    btMultiBody's default angular damping (0.04) it keeps 67 % of its angular momentum; with none (xcheck's runs),
    its momentum changes by 0.2 %, the semi-implicit step's own drift."""
    sc = resolve_scenario("boxes-complex")
    ctx = run_context(sc)

    def kept(damping):
        tr = simulate(ctx.inertia, path="multibody", q0=ctx.q0, omega0=ctx.omega0, dt=1e-3, duration=2.0,
                      angular_damping=damping)
        L = np.linalg.norm(world_momentum(ctx.inertia, tr.q, tr.omega), axis=1)
        return L[-1] / L[0]

    assert kept(DEFAULT_ANGULAR_DAMPING) == pytest.approx(0.67, abs=0.02)
    assert abs(kept(0.0) - 1) < 5e-3


def test_giving_a_maximal_body_an_inertia_alone_makes_it_static():
    """Finding (why xcheck passes the mass with the inertia): ``changeDynamics(localInertiaDiagonal=...)`` alone sets a
    maximal body's mass to 0, Bullet's static body: it keeps its orientation however it spins (100 steps at 2 rad/s);
    with the mass given again in the same call it turns."""
    p = _pybullet()
    turned = {}
    for give_mass in (False, True):
        client = p.connect(p.DIRECT)
        try:
            p.setGravity(0, 0, 0, physicsClientId=client)
            body = p.createMultiBody(baseMass=1.0, baseCollisionShapeIndex=-1, useMaximalCoordinates=True,
                                     physicsClientId=client)
            p.changeDynamics(body, -1, localInertiaDiagonal=[1.0, 2.0, 3.0], angularDamping=0.0,
                             physicsClientId=client, **({"mass": 1.0} if give_mass else {}))
            assert p.getDynamicsInfo(body, -1, physicsClientId=client)[0] == (1.0 if give_mass else 0.0)
            p.resetBaseVelocity(body, [0, 0, 0], [0.02, 2.0, 0.03], physicsClientId=client)
            for _ in range(100):
                p.stepSimulation(physicsClientId=client)
            turned[give_mass] = p.getBasePositionAndOrientation(body, physicsClientId=client)[1] != (0.0, 0.0, 0.0, 1.0)
        finally:
            p.disconnect(physicsClientId=client)
    assert turned == {False: False, True: True}


def test_the_league_has_bullets_live_rows_on_the_published_figures():
    """Truth: the benchmark's published Bullet and ODE rows (2015). On its complex case at 1 ms, today's PyBullet
    maximal-coordinate body lands on the published Bullet figures (momentum 0.0125, energy 0.0136) and its multibody
    on ODE's (0.0131, 0.0125), to two digits; the multibody with PyBullet's default damping loses 76 %."""
    from xcheck.league.run import bullet_rows

    rows = {r["method"]: r for path in ("maximal", "multibody", "multibody-default")
            for r in bullet_rows("complex", path, steps=(1e-3,))}
    assert rows["pybullet-maximal"]["momentum_error"] == pytest.approx(0.0125, abs=5e-5)
    assert rows["pybullet-maximal"]["energy_error"] == pytest.approx(0.0136, abs=5e-5)
    assert rows["pybullet-multibody"]["momentum_error"] == pytest.approx(0.0131, abs=5e-5)
    assert rows["pybullet-multibody"]["energy_error"] == pytest.approx(0.0125, abs=5e-5)
    assert rows["pybullet-multibody-default"]["momentum_error"] == pytest.approx(0.756, abs=0.01)
    assert all(np.isfinite(r["position_error"]) and r["position_error"] < 0.1 for r in rows.values())


@pytest.mark.parametrize("path", ["multibody", "maximal"])
def test_bullet_turns_a_body_right_by_a_quarter_pi_a_step_at_most(path):
    """Finding: both paths clamp the rate's angle a step at pi/4 (ANGULAR_MOTION_THRESHOLD = 0.5 * SIMD_HALF_PI in
    btTransformUtil::integrateTransform and btMultiBody's position step), keeping the rate's own axis vector: a step
    that should turn the body by x > pi/4 turns it by 2 atan(x tan(pi/8) / (pi/4)). Truth: a steady spin about a
    principal axis turns by h w exactly. At 10 rad/s, 1/20 s turns 0.5 rad (good); 1/10 s turns 0.9706 rad for 1 and
    1/5 s 1.6241 for 2 (to 1e-12, the formula), and xcheck fails those runs, saying why."""
    spin = np.array([0.0, 0.0, 10.0])
    for dt, ok in ((0.05, True), (0.1, False), (0.2, False)):
        tr = simulate(np.diag([1.0, 2.0, 3.0]), path=path, q0=[1, 0, 0, 0], omega0=spin, dt=dt, duration=1.0)
        assert tr.ok is ok, tr.message
        expected = 10 * dt if ok else 2 * np.arctan(10 * dt * np.tan(np.pi / 8) / (np.pi / 4))
        assert rot.attitude_error(tr.q[1], tr.q[0]) == pytest.approx(expected, abs=1e-12)
        assert clamped_turn(10 * dt) == pytest.approx(expected, abs=1e-15)
        if not ok:
            assert (f"turns {10 * dt:g} rad in a step of {dt:g} s, beyond Bullet's limit of pi/4 a step "
                    f"(ANGULAR_MOTION_THRESHOLD: btTransformUtil.h, btMultiBody.cpp), where it turns it by "
                    f"{expected:.3g} rad instead") in tr.message


def test_a_blow_up_is_called_a_blow_up_first():
    """Issue 60: Bullet's multibody on J = diag(1, 2, 3), w0 = (0.1, 10, 0.1) rad/s at 1/60 s lets the rate run to
    1.7e30 rad/s; a torque-free body's rate never exceeds |J w0| / J_min = 20.0025 rad/s (|L| conserved). The run
    says it blew up, with that bound, not that Bullet clamped its turn; at 1/240 s it does not blow up."""
    from xcheck.engines.bullet import simulate

    J, w0 = np.diag([1.0, 2.0, 3.0]), [0.1, 10.0, 0.1]
    bound = float(np.sqrt(0.1**2 + 20.0**2 + 0.3**2))  # |J w0| / 1
    coarse = simulate(J, path="multibody", q0=[1, 0, 0, 0], omega0=w0, dt=1 / 60, duration=20.0)
    assert coarse.status == "failed"
    assert coarse.message.startswith("pybullet-multibody: blew up: its body rate grew to ")
    assert f"(|J w0| / J_min = {bound:.3g} rad/s)" in coarse.message and "Bullet's limit" not in coarse.message
    fine = simulate(J, path="multibody", q0=[1, 0, 0, 0], omega0=w0, dt=1 / 240, duration=20.0)
    assert fine.ok and np.max(np.linalg.norm(fine.omega, axis=1)) <= bound * (1 + 1e-6)


def test_the_blow_up_rule_on_a_known_series():
    """The rule alone: rates within 10 times the bound pass, the first past it is named with its time."""
    from xcheck.trajectory import blow_up

    t = np.arange(4.0)
    J = np.diag([1.0, 2.0, 3.0])
    w = np.array([[0, 1, 0], [0, 15, 0], [0, 20.0, 0], [0, 25, 0]])  # bound |J w0| / 1 = 2 rad/s: 20 is the limit
    assert blow_up(t[:3], w[:3], J, [0, 1, 0], method="m") is None
    assert blow_up(t, w, J, [0, 1, 0], method="m").startswith("m: blew up: its body rate grew to 25 rad/s by t = 3 s")
    assert blow_up(t, np.zeros((4, 3)), J, [0, 0, 0], method="m") is None  # at rest: no bound to grow past
