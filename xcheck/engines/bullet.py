"""Bullet through PyBullet (PyPI ``pybullet``) as an engine (issue 40): one rigid body in a direct (headless)
physics client, stepped by Bullet's own integrator through either of its two paths.

* ``multibody``: a ``btMultiBody`` (reduced coordinates, Featherstone's algorithm: PyBullet's default path for
  ``createMultiBody``), the base floating. Bullet's multibodies carry an angular damping of 0.04 by default
  (``btMultiBody.cpp``: ``m_angularDamping(0.04f)``), which takes a third of a tumbling box's angular momentum in
  2 s: xcheck sets it to zero, and the finding says what the default costs.
* ``maximal``: a ``btRigidBody`` (``useMaximalCoordinates=True``), with Bullet's default gyroscopic term
  ``BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY`` (``btRigidBody.cpp``: one implicit step of Euler's equation in the
  body frame). ``changeDynamics`` with a ``localInertiaDiagonal`` alone sets a maximal body's mass to 0 (reported by
  ``getDynamicsInfo``): Bullet's static body, never moved, or with a collision shape one whose centre of mass gravity
  throws to -inf at the first step; xcheck gives the mass again in the same call (a test keeps this).

Both paths turn the body right by pi/4 a step at most (:data:`MAX_TURN`, :func:`clamped_turn` beyond): a run whose
steps would turn it further is failed, saying so. Both paths step semi-implicitly (the velocity first, then the
attitude with the new velocity): first order. The torque is applied through ``applyExternalTorque`` in world
components before each step, which Bullet clears after it: evaluated at the step's start and held over it (first
order, as the step itself).

A top and a gyrostat run on the multibody path, on Bullet's own joints (a maximal-coordinate body has none,
:func:`cannot`): the top a link on a ``JOINT_SPHERICAL`` at a fixed base (its state the joint's quaternion, body ->
world, and the body rate), under Bullet's gravity; the gyrostat's bus the floating base and each wheel a link on a ``JOINT_REVOLUTE``, a
motor's pulse a ``TORQUE_CONTROL`` command held over each step. ``createMultiBody`` gives every joint a motor (a
spherical joint's a servo toward its zero, which takes the top over: 41 rad/s after a step of 1 ms, from 15.7) and
every multibody a bound of 100 on each
coordinate's speed (:data:`DEFAULT_MAX_JOINT_VELOCITY`: RAX-1's wheel at 628 rad/s would run at 100); xcheck switches
both off, and the findings say what they cost.

Conventions at this boundary (a test round-trips them): Bullet's quaternions are scalar last ``[x, y, z, w]``,
body -> world; its angular velocity is in world components. Bullet's inertia is a diagonal in the body's inertial
frame: the body is run in its principal frame, ``q_principal = q ⊗ q_V`` and ``w_principal = V^T w`` with ``V`` the
principal axes (columns, body components), and converted back. Gravity is off (only the attitude is compared).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .. import rotations as rot
from ..body import principal_axes
from ..trajectory import Trajectory, blow_up, check_initial_state, finite_rows, step_plan, until_non_finite
from .held_input import engine_torque
from .mechanism import pulse_torque

__all__ = ["simulate", "free_flight", "PATHS", "to_bullet", "from_bullet", "DEFAULT_ANGULAR_DAMPING", "MAX_TURN",
           "clamped_turn", "cannot"]

#: Bullet's two paths for one body.
PATHS = ("multibody", "maximal")
#: The most Bullet turns a body right in a step [rad]: beyond it both paths clamp the rate's angle a step
#: (``ANGULAR_MOTION_THRESHOLD = 0.5 * SIMD_HALF_PI``, ``btTransformUtil::integrateTransform`` and
#: ``btMultiBody::stepPositionsMultiDof``) and turn the body by :func:`clamped_turn` instead; a run whose steps turn
#: further is reported failed, saying so.
MAX_TURN = math.pi / 4


def clamped_turn(turn: float) -> float:
    """What Bullet turns a body by in a step that should turn it by ``turn`` > pi/4 rad: the clamped angle's sine
    with the rate's own axis vector and the clamped cosine, ``[w sin(pi/8) / (pi/4 / h), cos(pi/8)]``, normalised:
    ``2 atan(turn tan(pi/8) / (pi/4))`` (0.971 rad for 1)."""
    return 2 * math.atan(turn * math.tan(math.pi / 8) / MAX_TURN) if turn > MAX_TURN else turn
#: ``btMultiBody``'s default bound on every coordinate's speed, its base's rate and joints' included [rad/s, m/s]:
#: ``m_maxCoordinateVelocity(100)``, applied by ``applyDeltaVeeMultiDof`` at every step (btMultiBody.cpp, .h).
DEFAULT_MAX_JOINT_VELOCITY = 100.0
#: The bound xcheck's multibodies run with (``changeDynamics(maxJointVelocity=...)``): none that a body reaches.
MAX_JOINT_VELOCITY = 1e30
#: ``btMultiBody``'s default angular damping (what ``createMultiBody`` gives a body unless it is changed).
DEFAULT_ANGULAR_DAMPING = 0.04


@functools.lru_cache(maxsize=1)
def _pybullet():
    """PyBullet, imported with its banner ("pybullet build time: ...", which C writes to the standard error as the
    module loads: ``pybullet.c``) kept off the terminal."""
    import os
    import sys

    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            import pybullet
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return pybullet


@functools.lru_cache(maxsize=1)
def _client() -> int:
    """This process's physics client (direct, headless), connected once: a connection and its disconnection cost
    13 ms, where a run of a quick study's coarsest step takes 2."""
    p = _pybullet()
    return p.connect(p.DIRECT)


def _world():
    """``(pybullet, client)`` with an empty world: the client's simulation reset (every body, the gravity, the
    engine's parameters), so that each run starts as in a new connection."""
    p = _pybullet()
    client = _client()
    p.resetSimulation(physicsClientId=client)
    return p, client


def to_bullet(q, omega, V):
    """Our ``(q, omega)`` (body -> world, body rate) of a body with principal axes ``V`` -> Bullet's ``(orientation
    [x, y, z, w] of the principal frame, angular velocity in world components)``."""
    qp = rot.quat_mul(q, rot.dcm_to_quat(V))
    w_world = rot.quat_rotate(q, omega)
    return np.concatenate([qp[..., 1:], qp[..., :1]], axis=-1), w_world


def from_bullet(orientation, w_world, V):
    """Bullet's ``(orientation [x, y, z, w] of the principal frame, world angular velocity)`` -> our ``(q, omega)``."""
    q = rot.quat_mul(_wxyz(orientation), rot.quat_conj(rot.dcm_to_quat(V)))
    return q, rot.quat_rotate(rot.quat_conj(q), np.asarray(w_world, dtype=float))


def _body(p, client, path: str, *, mass: float, moments, orientation, w_world, v0=(0.0, 0.0, 0.0),
          angular_damping: float = 0.0, max_joint_velocity: float = MAX_JOINT_VELOCITY) -> int:
    """One body on ``path`` at the origin: its principal moments, orientation (Bullet's), velocities (world), no
    linear damping, ``angular_damping`` (see the module's docstring)."""
    if path not in PATHS:
        raise ValueError(f"path: unknown {path!r}; expected one of {', '.join(PATHS)}")
    body = p.createMultiBody(baseMass=float(mass), baseCollisionShapeIndex=-1, basePosition=[0, 0, 0],
                             baseOrientation=list(map(float, orientation)), useMaximalCoordinates=path == "maximal",
                             physicsClientId=client)
    # the mass again: changeDynamics with an inertia alone sets a maximal body's mass to 0 (see the docstring)
    p.changeDynamics(body, -1, mass=float(mass), localInertiaDiagonal=list(map(float, moments)), linearDamping=0.0,
                     angularDamping=float(angular_damping), maxJointVelocity=float(max_joint_velocity),
                     physicsClientId=client)
    p.resetBaseVelocity(body, list(map(float, v0)), list(map(float, w_world)), physicsClientId=client)
    return body


def free_flight(*, path: str, mass: float, moments, omega0, v0, gravity, dt: float, nsteps: int,
                angular_damping: float = 0.0):
    """Bullet flying a body whole, translation and gravity included, as the boxes benchmark does
    (:mod:`xcheck.league`): principal ``moments`` along the body axes, the identity attitude at the origin, ``v0``
    [m/s] and ``omega0`` [rad/s] (the identity start makes body and world components alike), ``nsteps`` steps of
    ``dt``. Returns ``(t, c, q, v, omega)`` like :func:`xcheck.engines.mujoco.free_flight` (omega in body
    components)."""
    p, client = _world()
    p.setGravity(*map(float, gravity), physicsClientId=client)
    p.setPhysicsEngineParameter(fixedTimeStep=float(dt), numSubSteps=0, physicsClientId=client)
    body = _body(p, client, path, mass=mass, moments=moments, orientation=[0, 0, 0, 1], w_world=omega0, v0=v0,
                 angular_damping=angular_damping)
    c, orn, v, w = (np.empty((nsteps + 1, k)) for k in (3, 4, 3, 3))
    for k in range(nsteps + 1):
        if k:
            p.stepSimulation(physicsClientId=client)
        c[k], orn[k] = p.getBasePositionAndOrientation(body, physicsClientId=client)
        v[k], w[k] = p.getBaseVelocity(body, physicsClientId=client)
    q, omega = from_bullet(orn, w, np.eye(3))
    return np.arange(nsteps + 1) * float(dt), c, q, v, omega


def _top(p, client, top, q0, omega0, max_joint_velocity: float = MAX_JOINT_VELOCITY,
         joint_motor: bool = False) -> int:
    """A top on Bullet's multibody: a fixed base at the pivot (mass 0), one link on a spherical joint there, its
    inertial frame at the centre of mass along the principal axes (the link's frame is the body's). The spherical
    joint's motor, a servo toward the joint's zero which ``createMultiBody`` gives it, is switched off (kept with
    ``joint_motor``: the finding's test)."""
    moments, V = principal_axes(top.inertia)
    body = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=-1, basePosition=[0, 0, 0],
                             linkMasses=[float(top.mass)], linkCollisionShapeIndices=[-1],
                             linkVisualShapeIndices=[-1], linkPositions=[[0, 0, 0]], linkOrientations=[[0, 0, 0, 1]],
                             linkInertialFramePositions=[list(map(float, top.centre))],
                             linkInertialFrameOrientations=[_xyzw(rot.dcm_to_quat(V))], linkParentIndices=[0],
                             linkJointTypes=[p.JOINT_SPHERICAL], linkJointAxis=[[0, 0, 1]], physicsClientId=client)
    # the inertia alone: with the mass in the same call a link takes its collision shape's (none: zero)
    p.changeDynamics(body, 0, localInertiaDiagonal=list(map(float, moments)), physicsClientId=client)
    p.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, maxJointVelocity=float(max_joint_velocity),
                     physicsClientId=client)
    if not joint_motor:
        p.setJointMotorControlMultiDof(body, 0, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                       targetVelocity=[0, 0, 0], positionGain=0, velocityGain=0, force=[0, 0, 0],
                                       physicsClientId=client)
    p.resetJointStateMultiDof(body, 0, targetValue=_xyzw(q0), targetVelocity=list(map(float, omega0)),
                              physicsClientId=client)
    return body


def _gyrostat(p, client, gyro, orientation, w_world, V,
              max_joint_velocity: float = MAX_JOINT_VELOCITY) -> int:
    """A gyrostat on Bullet's multibody: the bus the floating base (its principal frame ``V``), each wheel a link on a
    revolute joint along its axis through the centre of mass, its velocity motor switched off (``createMultiBody``
    gives each joint one that holds it at rest)."""
    frames = [_xyzw(rot.dcm_to_quat(rot.frame_with_z(V.T @ w.axis))) for w in gyro.wheels]
    k = len(gyro.wheels)
    moments, _ = principal_axes(gyro.inertia)
    body = p.createMultiBody(baseMass=float(gyro.mass), baseCollisionShapeIndex=-1, basePosition=[0, 0, 0],
                             baseOrientation=list(map(float, orientation)),
                             linkMasses=[float(w.mass) for w in gyro.wheels], linkCollisionShapeIndices=[-1] * k,
                             linkVisualShapeIndices=[-1] * k, linkPositions=[[0, 0, 0]] * k,
                             linkOrientations=[[0, 0, 0, 1]] * k, linkInertialFramePositions=[[0, 0, 0]] * k,
                             linkInertialFrameOrientations=frames, linkParentIndices=[0] * k,
                             linkJointTypes=[p.JOINT_REVOLUTE] * k,
                             linkJointAxis=[list(map(float, V.T @ w.axis)) for w in gyro.wheels],
                             physicsClientId=client)
    p.changeDynamics(body, -1, mass=float(gyro.mass), localInertiaDiagonal=list(map(float, moments)),
                     linearDamping=0.0, angularDamping=0.0, maxJointVelocity=float(max_joint_velocity),
                     physicsClientId=client)
    for j, w in enumerate(gyro.wheels):
        p.changeDynamics(body, j, localInertiaDiagonal=[w.transverse, w.transverse, w.axial], physicsClientId=client)
        p.setJointMotorControl2(body, j, p.VELOCITY_CONTROL, force=0, physicsClientId=client)
        p.resetJointState(body, j, targetValue=0.0, targetVelocity=float(w.speed), physicsClientId=client)
    p.resetBaseVelocity(body, [0, 0, 0], list(map(float, w_world)), physicsClientId=client)
    return body


def _wxyz(orientation) -> np.ndarray:
    """Bullet's ``[x, y, z, w]`` rows as our ``[w, x, y, z]``."""
    orientation = np.asarray(orientation, dtype=float)
    return np.concatenate([orientation[..., 3:], orientation[..., :3]], axis=-1)


def _xyzw(q) -> list:
    """Our quaternion ``[w, x, y, z]`` as Bullet's ``[x, y, z, w]`` list."""
    q = np.asarray(q, dtype=float)
    return [float(q[1]), float(q[2]), float(q[3]), float(q[0])]


def cannot(path: str, mechanism) -> str | None:
    """Why Bullet's ``path`` cannot run the body ``mechanism`` (:func:`xcheck.engines.mechanism.mechanism_of`, or
    its class), or None: a maximal-coordinate body has no joints (Bullet joins such bodies by constraints its solver
    enforces approximately, ``createConstraint``), so a top or a gyrostat runs on the multibody path only."""
    if mechanism is not None and path == "maximal":
        from .mechanism import Top

        top = mechanism is Top or isinstance(mechanism, Top)
        what = "a top's ball joint" if top else "a gyrostat's wheels on hinges"
        return (f"Bullet's maximal-coordinate body has no joints: {what} would be a solver constraint "
                "(createConstraint), which xcheck does not run; pybullet-multibody runs it on its own joints")
    return None


def simulate(inertia, *, path: str, q0, omega0, dt: float, duration: float, torque=None, mass: float = 1.0,
             angular_damping: float = 0.0, max_joint_velocity: float = MAX_JOINT_VELOCITY,
             mechanism=None) -> Trajectory:
    """Run Bullet's ``path`` (:data:`PATHS`) on a body of ``inertia`` (3, 3) [kg m^2] from ``(q0, omega0)`` (ours)
    for ``duration`` s at step ``dt``; ``torque`` None or ``(t, q, omega) -> (3,)`` [N m] in body components, held
    over each step. ``angular_damping``, ``max_joint_velocity``: Bullet's (xcheck's runs: 0 and none; the findings:
    the multibody's defaults, :data:`DEFAULT_ANGULAR_DAMPING` and :data:`DEFAULT_MAX_JOINT_VELOCITY`).
    ``mechanism``: a top or a gyrostat (:mod:`xcheck.engines.mechanism`; the multibody path), built on Bullet's own
    joints with its gravity and the wheels' motors (their pulses held over each step); None: a free body."""
    q0, omega0 = check_initial_state(q0, omega0)
    n, last_h = step_plan(float(dt), float(duration))
    why = cannot(path, mechanism)
    if why is not None:
        raise ValueError(f"path: {why}")
    if path not in PATHS:
        raise ValueError(f"path: unknown {path!r}; expected one of {', '.join(PATHS)}")
    p, client = _world()
    p.setGravity(0, 0, 0, physicsClientId=client)
    wheels = ()
    if mechanism is not None and hasattr(mechanism, "centre"):  # a top: the link's frame is the body's
        V = np.eye(3)
        p.setGravity(*map(float, mechanism.gravity), physicsClientId=client)
        body = _top(p, client, mechanism, q0, omega0, max_joint_velocity)
        orientation, w_world = _xyzw(q0), rot.quat_rotate(q0, omega0)
        joint = functools.partial(p.getJointStateMultiDof, body, 0, physicsClientId=client)

        def pose():  # the spherical joint's quaternion (the base is the world's frame) and the link's body rate
            state = joint()
            return state[0], state[1]
        link, rates = 0, "body"
    else:
        moments, V = principal_axes(np.asarray(inertia if mechanism is None else mechanism.inertia, dtype=float))
        orientation, w_world = to_bullet(q0, omega0, V)
        if mechanism is None:
            body = _body(p, client, path, mass=mass, moments=moments, orientation=orientation, w_world=w_world,
                         angular_damping=angular_damping, max_joint_velocity=max_joint_velocity)
        else:
            body = _gyrostat(p, client, mechanism, orientation, w_world, V, max_joint_velocity)
            wheels = mechanism.wheels
        base_pose, base_rate = (functools.partial(f, body, physicsClientId=client) for f in
                                (p.getBasePositionAndOrientation, p.getBaseVelocity))

        def pose():
            return base_pose()[1], base_rate()[1]
        link, rates = -1, "world"
    t = np.arange(n + 1) * float(dt)
    t[-1] = float(duration)
    p.setPhysicsEngineParameter(fixedTimeStep=float(dt), numSubSteps=0, physicsClientId=client)
    step = functools.partial(p.stepSimulation, physicsClientId=client)
    orns, angs = [tuple(orientation)], [tuple(w_world) if rates == "world" else tuple(map(float, omega0))]
    if torque is not None:  # lists of Bullet's tuples: 3.3 us a step in Bullet's calls, 1 in Python's
        world_torque = engine_torque(torque, form="xyzw", right=rot.quat_conj(rot.dcm_to_quat(V)), rates=rates)
        push = functools.partial(p.applyExternalTorque, body, link, flags=p.WORLD_FRAME, physicsClientId=client)
    motors = [(j, w) for j, w in enumerate(wheels) if w.pulse is not None]
    for k in range(n):
        if k == n - 1 and last_h != dt:
            p.setPhysicsEngineParameter(fixedTimeStep=last_h, physicsClientId=client)
        if torque is not None:
            push(world_torque(t[k], np.array(orns[k]), np.array(angs[k])).tolist())
        for j, w in motors:  # TORQUE_CONTROL: for the next step only
            p.setJointMotorControl2(body, j, p.TORQUE_CONTROL, force=pulse_torque(w, t[k]), physicsClientId=client)
        step()
        orn, ang = pose()
        orns.append(orn)
        angs.append(ang)
    orn, ang = np.array(orns, dtype=float), np.array(angs, dtype=float)
    k = finite_rows(orn, ang)
    if rates == "world":
        q, omega = from_bullet(orn[:k], ang[:k], V)
    else:
        q, omega = _wxyz(orn[:k]), ang[:k]  # the joint's quaternion, body -> world; the body rate
    method = f"pybullet-{path}"
    traj = until_non_finite(t, q, omega, method=method, dt=dt, extras={
        "evaluations": n, "torque_input": "held over each step" if torque is not None or motors else None})
    burst = blow_up(traj.t, ang[:k], inertia, omega0, method=method) if torque is None and mechanism is None \
        and traj.ok else None
    if burst:  # a blow-up first (issue 60): past it, the turn a step below is the blow-up's, not Bullet's clamp
        traj.status, traj.message = "failed", burst
    turn = float(np.max(np.linalg.norm(ang[1:], axis=1) * np.diff(t))) if n and traj.ok else 0.0
    if turn > MAX_TURN:  # Bullet turned the body by less than its rate asks: not the step's answer
        traj.status, traj.message = "failed", (
            f"{method}: the body turns {turn:.3g} rad in a step of {float(dt):g} s, beyond Bullet's limit of pi/4 a "
            f"step (ANGULAR_MOTION_THRESHOLD: btTransformUtil.h, btMultiBody.cpp), where it turns it by "
            f"{clamped_turn(turn):.3g} rad instead")
    return traj
