"""DART (PyPI ``dartpy``) as an engine (issue 40): one body on a ``FreeJoint`` in a ``World`` with no gravity, stepped
by DART's own integrator, semi-implicit Euler (the velocity first, then the positions with the new velocity: order 1).

Conventions at this boundary (tested both ways, and against DART's own reading of the body): the joint's positions
are ``FreeJoint.convertToPositions`` of the body's transform, whose rotation is our ``R`` (body -> world); its
velocities, as ``dartpy`` 6.20 reads them, are the angular velocity in world components then the linear one: the
rate enters as ``R w``. A run reads the joint's state as it is at every step, ``getPositions()`` (the rotation vector
of ``R``, then the translation) and ``getVelocities()`` (0.9 us a step, where the body's transform and rate cost 6.5),
and converts the rows at the end (:func:`from_dart_state`; the same attitudes as DART's own transforms to 1e-15). The inertia is the
body-frame tensor, products included (``Inertia``).

The torque is set with ``setExtTorque`` in world components before each step (from the joint's state, compiled:
:func:`xcheck.engines.held_input.engine_torque`), which DART clears after it: evaluated
at the step's start and held over it (first order, as the step itself).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import rotations as rot
from ..trajectory import Trajectory, check_initial_state, finite_rows, step_plan, until_non_finite
from .held_input import engine_torque
from .mechanism import Top, pulse_torque

__all__ = ["simulate", "free_flight", "to_dart", "from_dart", "from_dart_state"]


@functools.lru_cache(maxsize=1)
def _dart():
    import dartpy

    return dartpy


def to_dart(q, omega) -> tuple[np.ndarray, np.ndarray]:
    """Our ``(q, omega)`` -> ``(R, the joint's velocities' angular part: R w, world components)``."""
    R = rot.quat_to_dcm(q)
    return R, R @ np.asarray(omega, dtype=float)


def from_dart(R, omega_body) -> tuple[np.ndarray, np.ndarray]:
    """DART's body rotation ``R`` (body -> world) and body-frame rate -> our ``(q, omega)``."""
    return rot.dcm_to_quat(np.asarray(R, dtype=float)), np.asarray(omega_body, dtype=float)


def from_dart_state(positions, velocities) -> tuple[np.ndarray, np.ndarray]:
    """A FreeJoint's positions ``[rotation vector of R, translation]`` and velocities ``[R w, v]`` rows -> our
    ``(q, omega)`` (body rate)."""
    q = rot.rotvec_to_quat(np.asarray(positions, dtype=float)[..., 0:3])
    return q, rot.quat_rotate(rot.quat_conj(q), np.asarray(velocities, dtype=float)[..., 0:3])


def _empty_world(dart, dt: float, gravity):
    """A World with ``gravity`` and the time step ``dt``."""
    world = dart.simulation.World()
    world.setGravity(np.asarray(gravity, dtype=float))
    world.setTimeStep(float(dt))
    return world


def _free_skeleton(dart, name: str, mass: float, inertia):
    """A skeleton of one body on a FreeJoint, its centre of mass at the joint: ``(skeleton, body)``."""
    skeleton = dart.dynamics.Skeleton(name)
    _, body = skeleton.createFreeJointAndBodyNodePair(None, dart.dynamics.FreeJointProperties())
    body.setInertia(dart.dynamics.Inertia(float(mass), np.zeros(3), np.asarray(inertia, dtype=float)))
    return skeleton, body


def _free_state(dart, q0, omega0):
    """A FreeJoint's ``(positions, velocities)`` for our ``(q0, omega0)``, at rest in translation at the origin."""
    R0, w_world = to_dart(q0, omega0)
    pose = dart.math.Isometry3()
    pose.set_rotation(R0)
    return dart.dynamics.FreeJoint.convertToPositions(pose), np.concatenate([w_world, np.zeros(3)])


def _world(dart, dt: float, gravity, inertia, mass: float = 1.0):
    """A World with one body on a FreeJoint: ``(world, skeleton, body)``."""
    world = _empty_world(dart, dt, gravity)
    skeleton, body = _free_skeleton(dart, "xcheck-body", mass, inertia)
    world.addSkeleton(skeleton)
    return world, skeleton, body


def free_flight(*, mass: float, moments, omega0, v0, gravity, dt: float, nsteps: int):
    """DART flying a body whole, translation and gravity included, as the boxes benchmark does
    (:mod:`xcheck.league`): principal ``moments`` along the body axes, the identity attitude at the origin, ``v0``
    and ``omega0`` (world and body components alike at the identity), ``nsteps`` steps of ``dt``. Returns
    ``(t, c, q, v, omega)`` like :func:`xcheck.engines.mujoco.free_flight`."""
    dart = _dart()
    world, skeleton, body = _world(dart, dt, gravity, np.diag(np.asarray(moments, dtype=float)), mass)
    skeleton.setVelocities(np.concatenate([np.asarray(omega0, dtype=float), np.asarray(v0, dtype=float)]))
    frame = dart.dynamics.Frame.World()
    c, Rs, v, w = np.empty((nsteps + 1, 3)), np.empty((nsteps + 1, 3, 3)), np.empty((nsteps + 1, 3)), \
        np.empty((nsteps + 1, 3))
    for k in range(nsteps + 1):
        if k:
            world.step()
        pose = body.getWorldTransform()
        c[k], Rs[k] = pose.translation(), pose.rotation()
        v[k], w[k] = body.getLinearVelocity(frame, frame), body.getAngularVelocity(frame, body)
    q, omega = from_dart(Rs, w)
    return np.arange(nsteps + 1) * float(dt), c, q, v, omega


def _top(dart, world, top, q0, omega0):
    """A top on DART's ``BallJoint`` at the world's origin (its positions the rotation vector of ``R``, its velocities
    the body rate), its inertia about the centre of mass ``top.centre`` from the joint: ``(skeleton, body)``."""
    skeleton = dart.dynamics.Skeleton("xcheck-top")
    _, body = skeleton.createBallJointAndBodyNodePair(None, dart.dynamics.BallJointProperties())
    body.setInertia(dart.dynamics.Inertia(float(top.mass), np.asarray(top.centre, dtype=float),
                                          np.asarray(top.inertia, dtype=float)))
    world.addSkeleton(skeleton)
    skeleton.setPositions(rot.quat_to_rotvec(q0))
    skeleton.setVelocities(np.asarray(omega0, dtype=float))
    return skeleton, body


def _gyrostat(dart, world, gyro, q0, omega0):
    """A gyrostat in DART: the bus on a ``FreeJoint``, each wheel a child on a ``RevoluteJoint`` along its axis
    through the centre of mass, at its speed relative to the bus: ``(skeleton, bus, wheel joints)``."""
    skeleton, bus = _free_skeleton(dart, "xcheck-gyrostat", gyro.mass, gyro.inertia)
    joints = []
    for w in gyro.wheels:
        props = dart.dynamics.RevoluteJointProperties()
        props.mAxis = np.asarray(w.axis, dtype=float)
        joint, wheel = skeleton.createRevoluteJointAndBodyNodePair(bus, props)
        wheel.setInertia(dart.dynamics.Inertia(float(w.mass), np.zeros(3), w.inertia))
        joints.append(joint)
    world.addSkeleton(skeleton)
    positions, velocities = _free_state(dart, q0, omega0)
    skeleton.setPositions(np.concatenate([positions, np.zeros(len(gyro.wheels))]))
    skeleton.setVelocities(np.concatenate([velocities, [w.speed for w in gyro.wheels]]))
    return skeleton, bus, joints


def simulate(inertia, *, q0, omega0, dt: float, duration: float, torque=None, mechanism=None) -> Trajectory:
    """Run DART's semi-implicit Euler at step ``dt`` on a free body of ``inertia`` (3, 3) [kg m^2] from
    ``(q0, omega0)`` (ours) for ``duration`` s; ``torque`` None or ``(t, q, omega) -> (3,)`` [N m] in body
    components, held over each step. ``mechanism``: a top or a gyrostat (:mod:`xcheck.engines.mechanism`) on DART's
    own joints, with its gravity and the wheels' motors (their pulses held over each step); None: a free body."""
    q0, omega0 = check_initial_state(q0, omega0)
    n, last_h = step_plan(float(dt), float(duration))
    dart = _dart()
    joints, top = [], isinstance(mechanism, Top)
    if top:
        world = _empty_world(dart, dt, mechanism.gravity)
        skeleton, body = _top(dart, world, mechanism, q0, omega0)
    elif mechanism is not None:
        world = _empty_world(dart, dt, np.zeros(3))
        skeleton, body, joints = _gyrostat(dart, world, mechanism, q0, omega0)
    else:
        world, skeleton, body = _world(dart, dt, np.zeros(3), inertia)
        positions, velocities = _free_state(dart, q0, omega0)
        skeleton.setPositions(positions)
        skeleton.setVelocities(velocities)
    width = skeleton.getNumDofs()
    positions = np.empty((n + 1, width))  # the joints' state, read as it is (0.9 us a step; the body's transform and
    velocities = np.empty((n + 1, width))  # rate, 6.5 us): [rotation vector, ...], [R w or w, ...]
    positions[0], velocities[0] = skeleton.getPositions(), skeleton.getVelocities()
    t = np.arange(n + 1) * float(dt)
    t[-1] = float(duration)
    rates = "body" if top else "world"
    world_torque = None if torque is None else engine_torque(torque, form="rotvec", rates=rates)
    motors = [(joint, w) for joint, w in zip(joints, mechanism.wheels if joints else ()) if w.pulse is not None]
    for k in range(n):
        if k == n - 1 and last_h != dt:
            world.setTimeStep(last_h)
        if world_torque is not None:
            body.setExtTorque(world_torque(t[k], positions[k, 0:3], velocities[k, 0:3]), False)
        for joint, w in motors:  # a joint's force: a command for the next step
            joint.setForce(0, pulse_torque(w, t[k]))
        world.step()
        positions[k + 1], velocities[k + 1] = skeleton.getPositions(), skeleton.getVelocities()
    k = finite_rows(positions, velocities)
    if top:
        q, omega = rot.rotvec_to_quat(positions[:k, 0:3]), velocities[:k, 0:3]
    else:
        q, omega = from_dart_state(positions[:k], velocities[:k])
    return until_non_finite(t, q, omega, method="dart-semi-implicit-euler", dt=dt, extras={
        "evaluations": n, "torque_input": "held over each step" if torque is not None or motors else None})
