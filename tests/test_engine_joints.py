"""Tops and gyrostats on the engines' own joints (issue 40): PyBullet's multibody, DART, Drake and EXUDYN build the
bundled heavy top on a ball joint under their own gravity and the gyrostats' wheels on hinges (a motor's pulse
included), from the MJCF's numbers (:mod:`xcheck.engines.mechanism`). Each is checked against the scenario's truth
(Lagrange's top and the axisymmetric gyrostat in closed form, DOP853 for the tumbler's three wheels) at its own
order; the conversions at each joint both ways and against the engine's own reading; the bodies an engine cannot
build are refused, saying why; and the findings: the defaults ``createMultiBody`` gives a joint, Bullet's bound on a
coordinate's speed, EXUDYN's explicit solvers on a pivot. Each engine's part is skipped, saying so, where it is not
installed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.engines import available
from xcheck.engines.mechanism import Gyrostat, Top, mechanism_of
from xcheck.runners import RUNNERS
from xcheck.scenario import resolve_scenario
from xcheck.study.context import run_context, scenario_reference

def needs(engine: str):
    """Skip, saying why, where ``engine`` is not installed or is left out here."""
    if not available(engine):
        pytest.skip(f"{engine} is not installed or is left out here (pip install 'xcheck[engines]')")


def context(name: str, duration: float = 1.0):
    sc = resolve_scenario(name)
    return sc, dataclasses.replace(run_context(sc), duration=duration)


def errors_at(method: str, name: str, dts, duration: float = 1.0) -> list[float]:
    """The largest attitude error [rad] over ``duration`` s of ``method`` at each step, against the scenario's truth."""
    sc, ctx = context(name, duration)
    ref = scenario_reference(sc)
    out = []
    for dt in dts:
        tr = RUNNERS[method].run(ctx, dt)
        assert tr.ok, tr.message
        q, _, mask = ref.at(tr.t)
        out.append(float(np.max(rot.attitude_error(tr.q[mask], q[mask]))))
    return out


def local_orders(dts, errors) -> np.ndarray:
    return np.log(np.array(errors[:-1]) / errors[1:]) / np.log(np.array(dts[:-1]) / dts[1:])


EULER = (1 / 256, 1 / 512, 1 / 1024, 1 / 2048)
HIGHER = (1 / 128, 1 / 256, 1 / 512)

#: (method, order, steps, (scenario, largest error at the finest step [rad])...), measured on 1 s of each; the bounds
#: are the measured errors with 10-30 % to spare.
CASES = [
    ("pybullet-multibody", 1, EULER, {"heavy-top": 2.5e-3, "gyrostat-axisymmetric": 1.8e-4,
                                      "tumbler-three-wheels": 2.7e-5}),
    ("dart-semi-implicit-euler", 1, EULER, {"heavy-top": 2.5e-3, "gyrostat-axisymmetric": 1.8e-4,
                                            "tumbler-three-wheels": 2.7e-5}),
    ("drake-semi-explicit-euler", 1, EULER, {"heavy-top": 8.6e-3}),
    ("drake-rk2", 2, HIGHER, {"heavy-top": 3.8e-4, "gyrostat-axisymmetric": 9.6e-7, "tumbler-three-wheels": 1.9e-7}),
    ("drake-rk3", 3, HIGHER, {"heavy-top": 3.3e-6, "gyrostat-axisymmetric": 8.9e-10,
                              "tumbler-three-wheels": 6.2e-11}),
    ("exudyn-generalized-alpha", 2, HIGHER, {"heavy-top": 1.3e-5}),
    ("exudyn-trapezoidal-index2", 2, HIGHER, {"heavy-top": 1.3e-5}),
]


@pytest.mark.parametrize("method, order, dts, bounds", CASES, ids=[c[0] for c in CASES])
def test_each_engine_runs_the_top_and_the_gyrostats_at_its_own_order(method, order, dts, bounds):
    """Truth: Lagrange's top and the axisymmetric gyrostat in closed form, DOP853 for the tumbler whose x wheel a
    motor spins up over its first second. Each engine on its own joints converges to it at its method's order: the
    local orders between successive steps within 0.1 of it at the two finest (a top's Euler methods approach 1 from
    above: 1.06, 1.03, 1.01), and its error at the finest step under the measured bound."""
    needs(method.split("-")[0])
    for name, bound in bounds.items():
        errors = errors_at(method, name, dts)
        orders = local_orders(dts, errors)
        assert np.all(np.abs(orders[-2:] - order) < 0.1), (name, errors, orders)
        assert errors[-1] < bound, (name, errors)


def test_bullet_dart_and_mujoco_take_the_same_step_on_joints():
    """Finding: on a top's ball joint and a gyrostat's hinges, Bullet's multibody, DART and MuJoCo's Euler are one
    scheme (semi-implicit Euler in the joints' coordinates, the rotation by its exponential): their trajectories agree
    to 1e-9 rad, where each is 1e-2 to 1e-4 rad off the truth."""
    needs("pybullet")
    needs("dart")
    for name in ("heavy-top", "gyrostat-axisymmetric", "tumbler-three-wheels"):
        _, ctx = context(name)
        methods = ("mujoco-euler", "pybullet-multibody", "dart-semi-implicit-euler")
        runs = [RUNNERS[m].run(ctx, 1 / 512) for m in methods]
        for other in runs[1:]:
            assert float(np.max(rot.attitude_error(other.q, runs[0].q))) < 1e-9, name


def test_the_mechanisms_keep_the_bodys_inertia():
    """Truth: the MJCF's own numbers. A top's inertia about its centre of mass and the parallel axes give back the
    inertia about the pivot; a gyrostat's bus and wheels (each its axial moment and half of it across) give back the
    whole body's inertia, wheels included (:meth:`xcheck.models.MJCFBody.mass_inertia`), to 1e-15."""
    _, ctx = context("heavy-top")
    top = mechanism_of(ctx)
    assert isinstance(top, Top)
    np.testing.assert_allclose(top.about_pivot, ctx.inertia, atol=1e-15)
    np.testing.assert_allclose(top.gravity, [0, 0, -9.81])
    assert top.mass == pytest.approx(2.02) and top.centre[2] == pytest.approx(0.010049504950495)
    for name in ("gyrostat-axisymmetric", "tumbler-three-wheels", "rax1-momentum-bias"):
        _, ctx = context(name)
        gyro = mechanism_of(ctx)
        assert isinstance(gyro, Gyrostat)
        whole = gyro.inertia + sum(w.inertia for w in gyro.wheels)
        np.testing.assert_allclose(whole, ctx.body.mass_inertia(), atol=1e-15)
        assert gyro.mass + sum(w.mass for w in gyro.wheels) == pytest.approx(ctx.body.mass)
    assert mechanism_of(context("gyroscope-nonsingular")[1]) is None


def test_the_bodies_an_engine_cannot_build_are_refused_saying_why():
    """Bullet's maximal-coordinate body has no joints; EXUDYN's explicit solvers zero a pivot's coordinates rather than
    solve for it, and no EXUDYN solver runs wheels here. Each refusal names the reason, and the free bodies run."""
    top, wheels, free = (str(resolve_scenario(n).model) for n in ("heavy-top", "gyrostat-axisymmetric",
                                                                  "gyroscope-nonsingular"))
    if available("pybullet"):
        assert "no joints" in RUNNERS["pybullet-maximal"].cannot_run(top)
        assert "no joints" in RUNNERS["pybullet-maximal"].cannot_run(wheels)
        assert RUNNERS["pybullet-multibody"].cannot_run(top) is None
    if available("exudyn"):
        assert "eliminateConstraints" in RUNNERS["exudyn-rk44"].cannot_run(top)
        assert RUNNERS["exudyn-generalized-alpha"].cannot_run(top) is None
        assert "revolute-joint" in RUNNERS["exudyn-generalized-alpha"].cannot_run(wheels)
    for method in ("dart-semi-implicit-euler", "drake-rk3", "exudyn-rk44", "pybullet-maximal"):
        if method in RUNNERS:
            assert RUNNERS[method].cannot_run(free) is None


# -- the conversions at each joint, both ways and against the engine's own reading -------------------------------

Q = rot.quat_normalize(np.array([0.9, 0.2, -0.3, 0.25]))
W = np.array([0.5, -0.2, 15.71])


def test_bullets_spherical_joint_reads_as_xcheck_writes_it():
    """Bullet's own reading of the top's link (``getLinkState``): its world orientation is our ``q`` (scalar last)
    and its world angular velocity ``R w``, to 1e-12; the joint's state reads back as ``(q, w)``."""
    needs("pybullet")
    from xcheck.engines.bullet import _top, _world

    _, ctx = context("heavy-top")
    p, client = _world()
    body = _top(p, client, mechanism_of(ctx), Q, W)
    state = p.getLinkState(body, 0, computeLinkVelocity=1, physicsClientId=client)
    np.testing.assert_allclose(state[5], [*Q[1:], Q[0]], atol=1e-7)  # Bullet's link frame: float32 arithmetic
    np.testing.assert_allclose(state[7], rot.quat_rotate(Q, W), atol=1e-12)
    joint = p.getJointStateMultiDof(body, 0, physicsClientId=client)
    np.testing.assert_allclose([joint[0][3], *joint[0][:3]], Q, atol=1e-15)
    np.testing.assert_allclose(joint[1], W, atol=1e-15)


def test_darts_ball_joint_reads_as_xcheck_writes_it():
    """DART's own reading of the top's body: its world rotation is ``R`` and its angular velocity in the world ``R w``
    (in the body, ``w``), to 1e-13; its ball joint's positions are the rotation vector of ``R``."""
    needs("dart")
    from xcheck.engines.dart import _dart, _top

    dart = _dart()
    _, ctx = context("heavy-top")
    world = dart.simulation.World()
    _, body = _top(dart, world, mechanism_of(ctx), Q, W)
    world_frame = dart.dynamics.Frame.World()
    np.testing.assert_allclose(body.getWorldTransform().rotation(), rot.quat_to_dcm(Q), atol=1e-13)
    np.testing.assert_allclose(body.getAngularVelocity(world_frame, world_frame), rot.quat_rotate(Q, W), atol=1e-13)
    np.testing.assert_allclose(body.getAngularVelocity(world_frame, body), W, atol=1e-13)


@pytest.mark.parametrize("engine, integrator, atol", [("drake", "rk3", 1e-12), ("exudyn", "generalized-alpha", 1e-13)])
def test_drakes_and_exudyns_tops_read_as_xcheck_writes_them(engine, integrator, atol):
    """The first row of a run, xcheck's reading of the engine's own state at the start (Drake's logged roll-pitch-yaw
    and world rate; EXUDYN's sensors, ``RotationMatrix`` and ``AngularVelocityLocal`` of the node at the pivot), is
    the ``(q, w)`` given, to 1e-12 (Drake) and 1e-13 (EXUDYN)."""
    import importlib

    needs(engine)
    simulate = importlib.import_module(f"xcheck.engines.{'exu' if engine == 'exudyn' else engine}").simulate
    _, ctx = context("heavy-top")
    tr = simulate(ctx.inertia, integrator=integrator, q0=Q, omega0=W, dt=1 / 64, duration=1 / 16,
                  mechanism=mechanism_of(ctx))
    assert tr.ok, tr.message
    np.testing.assert_allclose(np.abs(tr.q[0] @ Q), 1.0, atol=atol)
    np.testing.assert_allclose(tr.omega[0], W, atol=atol)


# -- the findings -------------------------------------------------------------------------------------------------

def test_create_multibody_gives_a_spherical_joint_a_motor_that_takes_the_top_over():
    """Finding: ``createMultiBody`` gives a spherical joint a servo motor (btMultiBodySphericalJointMotor, toward the
    joint's zero): left on, the top's rate after one step of 1 ms is 41 rad/s, from 15.7; with the motor off, as
    xcheck runs it, the rate's size changes by less than 0.1 % (gravity's torque is all that acts)."""
    needs("pybullet")
    from xcheck.engines.bullet import _top, _world

    _, ctx = context("heavy-top")
    top = mechanism_of(ctx)
    rates = []
    for joint_motor in (False, True):
        p, client = _world()
        body = _top(p, client, top, Q, W, joint_motor=joint_motor)
        p.setPhysicsEngineParameter(fixedTimeStep=1e-3, numSubSteps=0, physicsClientId=client)
        p.stepSimulation(physicsClientId=client)
        rates.append(np.linalg.norm(p.getJointStateMultiDof(body, 0, physicsClientId=client)[1]))
    assert rates[0] == pytest.approx(np.linalg.norm(W), rel=1e-3)
    assert 35 < rates[1] < 45


def test_bullet_bounds_every_coordinates_speed_at_100_by_default():
    """Finding: ``btMultiBody`` clamps every coordinate's speed, its base's rate included, to
    ``m_maxCoordinateVelocity`` = 100 at every step (``applyDeltaVeeMultiDof``). A body spinning at 150 rad/s about its
    major axis spins at 100 after one step with the default; at 150 (to 1e-9) with xcheck's bound. RAX-1's wheel at
    628 rad/s is 0.63 rad off after 10 s at 1/128 s with the default, where MuJoCo's Euler is 1.6e-3."""
    needs("pybullet")
    from xcheck.engines.bullet import DEFAULT_MAX_JOINT_VELOCITY, simulate

    inertia = np.diag([1.0, 2.0, 3.0])
    spin = np.array([0.0, 0.0, 150.0])
    ours = simulate(inertia, path="multibody", q0=[1, 0, 0, 0], omega0=spin, dt=1e-4, duration=1e-3)
    clamped = simulate(inertia, path="multibody", q0=[1, 0, 0, 0], omega0=spin, dt=1e-4, duration=1e-3,
                       max_joint_velocity=DEFAULT_MAX_JOINT_VELOCITY)
    assert np.linalg.norm(ours.omega[-1]) == pytest.approx(150.0, abs=1e-9)
    assert np.linalg.norm(clamped.omega[1]) == pytest.approx(100.0, abs=1e-6)


def test_exudyns_explicit_solvers_turn_a_pivoted_top_as_a_free_body():
    """Finding (why EXUDYN's explicit solvers do not run tops): with ``explicit.eliminateConstraints`` a ground
    ``CoordinateConstraint`` is met by zeroing the coordinate and its rate after each evaluation, not by solving for
    the pivot's reaction: its RK44 on the heavy top is 0.59 rad off Lagrange's top after 1 s, at 1/256 s as at
    1/512 s (no convergence), where its generalized-alpha is 5e-5 rad off at 1/256 s. Truth: the closed form."""
    needs("exudyn")
    from xcheck.engines.exu import _simulate

    sc, ctx = context("heavy-top")
    ref = scenario_reference(sc)
    off = {}
    for integrator, dt in (("rk44", 1 / 256), ("rk44", 1 / 512), ("generalized-alpha", 1 / 256)):
        tr = _simulate(ctx.inertia, integrator=integrator, q0=ctx.q0, omega0=ctx.omega0, dt=dt, duration=1.0,
                       mechanism=mechanism_of(ctx))
        q, _, _ = ref.at(tr.t[-1:])
        off[integrator, dt] = float(rot.attitude_error(tr.q[-1], q[0]))
    assert 0.5 < off["rk44", 1 / 256] < 0.7 and abs(off["rk44", 1 / 512] - off["rk44", 1 / 256]) < 1e-3
    assert off["generalized-alpha", 1 / 256] < 1e-4
