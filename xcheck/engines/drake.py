"""Drake (PyPI ``drake``) as an engine (issue 40): one free body in a continuous ``MultibodyPlant`` (``time_step =
0``), run by the integrators of Drake's ``Simulator`` in fixed-step mode, chosen by name through
``ResetIntegratorFromFlags`` (``pydrake.systems.analysis``): explicit Euler, semi-explicit Euler, second- and
third-order Runge-Kutta (:data:`INTEGRATORS`).

Conventions at this boundary (tested both ways, and against Drake's own reading of the pose): the free body's state
is ``[q_WB (w, x, y, z), p_WB, w_WB (world components), v_WB]``; ``q_WB`` maps body components to world ones, as our
``q`` does, so it enters unchanged; the rate enters as ``R w`` and comes back as ``R^T w``. Drake integrates the
quaternion's four components as they are (its norm drifts with the integrator's error): xcheck normalises them when
it reads the state, as Drake's own ``GetFreeBodyPose`` does. The inertia is the body-frame tensor, products included
(``RotationalInertia``); gravity is off (only the attitude is compared).

The torque is a ``LeafSystem`` of xcheck's feeding the plant's applied spatial force port: Drake evaluates it with
the state of every stage, so the integrators keep their orders under attitude-dependent torques. The state is logged
every ``dt`` by Drake's ``VectorLogSink`` (no Python between steps of a torque-free run).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import rotations as rot
from ..trajectory import Trajectory, finite_rows, fixed_step_start, quaternion_rows, until_non_finite
from .held_input import engine_torque
from .mechanism import Top

__all__ = ["simulate", "free_flight", "INTEGRATORS", "to_drake", "from_drake"]

#: Our names -> (Drake's integrator name for ResetIntegratorFromFlags, order, derivative evaluations a step).
INTEGRATORS = {"explicit-euler": ("explicit_euler", 1, 1), "semi-explicit-euler": ("semi_explicit_euler", 1, 1),
               "rk2": ("runge_kutta2", 2, 2), "rk3": ("runge_kutta3", 3, 3)}


@functools.lru_cache(maxsize=1)
def _drake():
    from types import SimpleNamespace

    from pydrake.common.value import AbstractValue
    from pydrake.multibody.math import SpatialForce
    from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
    from pydrake.math import RollPitchYaw, RotationMatrix
    from pydrake.multibody.tree import BallRpyJoint, RevoluteJoint, RotationalInertia, SpatialInertia
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import LogVectorOutput, SymbolicVectorSystem

    return SimpleNamespace(AbstractValue=AbstractValue, SpatialForce=SpatialForce,
                           ExternallyAppliedSpatialForce=ExternallyAppliedSpatialForce, MultibodyPlant=MultibodyPlant,
                           RotationalInertia=RotationalInertia, SpatialInertia=SpatialInertia,
                           BallRpyJoint=BallRpyJoint, RevoluteJoint=RevoluteJoint, RollPitchYaw=RollPitchYaw,
                           RotationMatrix=RotationMatrix,
                           ResetIntegratorFromFlags=ResetIntegratorFromFlags, Simulator=Simulator,
                           DiagramBuilder=DiagramBuilder, LeafSystem=LeafSystem, LogVectorOutput=LogVectorOutput,
                           SymbolicVectorSystem=SymbolicVectorSystem)


def to_drake(q, omega) -> np.ndarray:
    """Our ``(q, omega)`` -> the attitude part of Drake's free-body state, ``[q_WB (4), w_WB (3, world)]``."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q, rot.quat_rotate(q, omega)], axis=-1)


def from_drake(state) -> tuple[np.ndarray, np.ndarray]:
    """Drake's ``[q_WB (4), w_WB (3)]`` rows -> our ``(q, omega)`` (the quaternion normalised, the rate in body
    components)."""
    state = np.asarray(state, dtype=float)
    q = state[..., 0:4] / np.linalg.norm(state[..., 0:4], axis=-1, keepdims=True)
    return q, rot.quat_rotate(rot.quat_conj(q), state[..., 4:7])


def _torque_system(d, state_size: int, attitude, form: str, body_index, torque):
    """A LeafSystem whose output is ``torque(t, q, omega)`` (body components) on the body ``body_index``, as Drake's
    applied spatial forces, from the plant's state ``x`` at each evaluation (every stage): the attitude read by
    ``attitude(x) -> (attitude in form, world rate)`` (``form``: :func:`engine_torque`'s)."""

    world_torque = engine_torque(torque, form=form, rates="world")
    force = d.ExternallyAppliedSpatialForce()  # one, its torque set at each evaluation (set_value copies it)
    force.body_index = body_index
    force.p_BoBq_B = np.zeros(3)
    zero = np.zeros(3)

    class Torque(d.LeafSystem):
        def __init__(self):
            super().__init__()
            self.port = self.DeclareVectorInputPort("state", state_size)
            self.DeclareAbstractOutputPort("forces", lambda: d.AbstractValue.Make([d.ExternallyAppliedSpatialForce()]),
                                           self._calc)

        def _calc(self, context, output):
            att, w = attitude(self.port.Eval(context))
            force.F_Bq_W = d.SpatialForce(world_torque(context.get_time(), att, w), zero)
            output.set_value([force])

    return Torque()


def _pulse_system(d, nv: int, wheels):
    """The wheels' motors' pulses (``wheels``: ``(velocity index, EngineWheel)``) as the plant's applied generalized
    forces: a ``SymbolicVectorSystem`` of time, which Drake evaluates at every stage in C++ (1 us an evaluation, where
    a Python LeafSystem took 5: a third of the tumbler's step), ``peak sin^2(pi (t - t0) / (t1 - t0))`` on
    ``[t0, t1]`` (:func:`xcheck.engines.mechanism.pulse_torque`)."""
    from pydrake.symbolic import Variable, if_then_else, sin

    t, still = Variable("t"), Variable("still")  # a state that stays 0: without one Drake 1.51 asks the system for
    out = [0.0 * t] * nv  # its (empty) derivatives and fails
    for i, w in wheels:
        if w.pulse is not None:
            peak, t0, t1 = map(float, w.pulse)
            out[i] = if_then_else(t <= t0, 0.0, if_then_else(t >= t1, 0.0,
                                                             peak * sin(np.pi * (t - t0) / (t1 - t0)) ** 2))
    return d.SymbolicVectorSystem(time=t, state=[still], dynamics=[0.0 * still], output=out)


def _connect_torque(builder, plant, system) -> None:
    """Add :func:`_torque_system`'s ``system``, the plant's state in and its forces out."""
    system = builder.AddSystem(system)
    builder.Connect(plant.get_state_output_port(), system.get_input_port(0))
    builder.Connect(system.get_output_port(0), plant.get_applied_spatial_force_input_port())


def _simulate(d, builder, plant, set_state, *, integrator: str, dt: float, duration: float):
    """Build the diagram, set the plant's state (``set_state(plant, plant context)``), run Drake's ``integrator`` at
    the fixed step ``dt`` for ``duration`` s: ``(times, states)``, logged every step."""
    logger = d.LogVectorOutput(plant.get_state_output_port(), builder, publish_period=float(dt))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    set_state(plant, plant.GetMyMutableContextFromRoot(context))
    simulator = d.Simulator(diagram, context)
    integ = d.ResetIntegratorFromFlags(simulator, INTEGRATORS[integrator][0], float(dt))
    integ.set_fixed_step_mode(True)
    simulator.Initialize()
    try:
        simulator.AdvanceTo(float(duration))
    except RuntimeError as exc:  # a ball joint's roll-pitch-yaw at gimbal lock, a blown-up state: what was logged
        error = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    else:
        error = None
    diagram.ForcedPublish(context)  # the end: a periodic publish at exactly the duration is not guaranteed
    log = logger.FindLog(context)
    times = np.asarray(log.sample_times(), dtype=float)
    data = np.asarray(log.data(), dtype=float).T
    keep = np.concatenate([np.diff(times) > 0.5 * dt, [True]])  # the forced publish may repeat the last sample
    return times[keep], data[keep], error


def _run(inertia, *, mass: float, integrator: str, state0, dt: float, duration: float, gravity, torque=None):
    """Drake's ``integrator`` at the fixed step ``dt`` on one free body (``inertia`` (3, 3) about its centre of mass,
    ``mass``) from the plant state ``state0`` ``[q_WB, p_WB, w_WB, v_WB]`` (13,) for ``duration`` s under ``gravity``,
    ``torque`` a LeafSystem's input at every stage: ``(times, states (n + 1, 13))``, logged every step."""
    d = _drake()
    builder = d.DiagramBuilder()
    plant = builder.AddSystem(d.MultibodyPlant(0.0))
    body = plant.AddRigidBody("body", _spatial_inertia(d, mass, np.zeros(3), inertia))
    plant.mutable_gravity_field().set_gravity_vector(np.asarray(gravity, dtype=float))
    plant.Finalize()
    if torque is not None:
        _connect_torque(builder, plant, _torque_system(d, 13, lambda x: (x[0:4], x[7:10]), "wxyz", body.index(),
                                                       torque))
    times, data, _ = _simulate(d, builder, plant, lambda p, c: p.SetPositionsAndVelocities(
        c, np.asarray(state0, dtype=float)), integrator=integrator, dt=dt, duration=duration)
    return times, data


def _spatial_inertia(d, mass: float, centre, inertia):
    """Drake's spatial inertia of a body of ``mass``, its centre of mass ``centre`` (body frame) and ``inertia``
    (3, 3) about it."""
    I = np.asarray(inertia, dtype=float)
    return d.SpatialInertia.MakeFromCentralInertia(float(mass), np.asarray(centre, dtype=float), d.RotationalInertia(
        I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))


def _run_top(top, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None):
    """A top on Drake's ``BallRpyJoint`` at the world's origin (its positions roll-pitch-yaw of ``R``, its velocities
    the rate in world components), its own gravity: ``(times, q, omega, error)``."""
    d = _drake()
    builder = d.DiagramBuilder()
    plant = builder.AddSystem(d.MultibodyPlant(0.0))
    body = plant.AddRigidBody("top", _spatial_inertia(d, top.mass, top.centre, top.inertia))
    joint = plant.AddJoint(d.BallRpyJoint("pivot", plant.world_frame(), body.body_frame()))
    plant.mutable_gravity_field().set_gravity_vector(np.asarray(top.gravity, dtype=float))
    plant.Finalize()

    def attitude(x):
        return d.RollPitchYaw(x[0:3]).ToRotationMatrix().matrix().ravel(), x[3:6]
    if torque is not None:
        _connect_torque(builder, plant, _torque_system(d, 6, attitude, "dcm", body.index(), torque))
    R0 = rot.quat_to_dcm(q0)

    def set_state(p, c):
        joint.set_angles(c, d.RollPitchYaw(d.RotationMatrix(R0)).vector())
        joint.set_angular_velocity(c, R0 @ np.asarray(omega0, dtype=float))
    times, data, error = _simulate(d, builder, plant, set_state, integrator=integrator, dt=dt, duration=duration)
    k = finite_rows(data)
    R = np.array([d.RollPitchYaw(x[0:3]).ToRotationMatrix().matrix() for x in data[:k]]).reshape(-1, 3, 3)
    q = rot.dcm_to_quat(R)
    return times, q, np.einsum("nji,nj->ni", R, data[:k, 3:6]), error


def _run_gyrostat(gyro, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None):
    """A gyrostat in Drake: the bus a free body, each wheel a body on a ``RevoluteJoint`` along its axis through the
    centre of mass, its motor's pulse an applied generalized force at every stage: ``(times, q, omega, error)``."""
    d = _drake()
    builder = d.DiagramBuilder()
    plant = builder.AddSystem(d.MultibodyPlant(0.0))
    bus = plant.AddRigidBody("bus", _spatial_inertia(d, gyro.mass, np.zeros(3), gyro.inertia))
    joints = []
    for i, w in enumerate(gyro.wheels):
        wheel = plant.AddRigidBody(f"wheel{i}", _spatial_inertia(d, w.mass, np.zeros(3), w.inertia))
        joints.append(plant.AddJoint(d.RevoluteJoint(f"hinge{i}", bus.body_frame(), wheel.body_frame(),
                                                     np.asarray(w.axis, dtype=float))))
    plant.mutable_gravity_field().set_gravity_vector(np.zeros(3))
    plant.Finalize()
    nq = plant.num_positions()
    qs, vs = bus.floating_positions_start(), nq + bus.floating_velocities_start_in_v()
    state_size = nq + plant.num_velocities()
    if torque is not None:
        _connect_torque(builder, plant, _torque_system(d, state_size, lambda x: (x[qs:qs + 4], x[vs:vs + 3]), "wxyz",
                                                       bus.index(), torque))
    if any(w.pulse is not None for w in gyro.wheels):
        pulses = builder.AddSystem(_pulse_system(d, plant.num_velocities(),
                                                 [(j.velocity_start(), w) for j, w in zip(joints, gyro.wheels)]))
        builder.Connect(pulses.get_output_port(0), plant.get_applied_generalized_force_input_port())
    start = to_drake(q0, omega0)

    def set_state(p, c):
        x = np.zeros(state_size)
        x[qs:qs + 4], x[vs:vs + 3] = start[0:4], start[4:7]
        for j, w in zip(joints, gyro.wheels):
            x[nq + j.velocity_start()] = w.speed
        p.SetPositionsAndVelocities(c, x)
    times, data, error = _simulate(d, builder, plant, set_state, integrator=integrator, dt=dt, duration=duration)
    k = quaternion_rows(data[:, qs:qs + 4], data)
    q, omega = from_drake(np.concatenate([data[:k, qs:qs + 4], data[:k, vs:vs + 3]], axis=1))
    return times, q, omega, error


def free_flight(*, integrator: str, mass: float, moments, omega0, v0, gravity, dt: float, nsteps: int):
    """Drake's ``integrator`` flying a body whole, translation and gravity included, as the boxes benchmark does
    (:mod:`xcheck.league`): principal ``moments`` along the body axes, the identity attitude at the origin, ``v0`` and
    ``omega0`` (world and body components alike at the identity), ``nsteps`` steps of ``dt``. Returns ``(t, c, q, v,
    omega)`` like :func:`xcheck.engines.mujoco.free_flight` (omega in body components)."""
    state0 = np.concatenate([[1.0, 0.0, 0.0, 0.0], np.zeros(3), np.asarray(omega0, dtype=float),
                             np.asarray(v0, dtype=float)])
    times, data = _run(np.diag(np.asarray(moments, dtype=float)), mass=mass, integrator=integrator, state0=state0,
                       dt=dt, duration=nsteps * float(dt), gravity=gravity)
    q, omega = from_drake(np.concatenate([data[:, 0:4], data[:, 7:10]], axis=1))
    return times, data[:, 4:7], q, data[:, 10:13], omega


def simulate(inertia, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None,
             mechanism=None) -> Trajectory:
    """Run Drake's ``integrator`` (:data:`INTEGRATORS`) at the fixed step ``dt`` on a free body of ``inertia`` (3, 3)
    [kg m^2] from ``(q0, omega0)`` (ours) for ``duration`` s; ``torque`` None or ``(t, q, omega) -> (3,)`` [N m] in
    body components, evaluated at every stage. ``mechanism``: a top on Drake's ball joint (roll-pitch-yaw: a run that
    reaches its gimbal lock fails saying so) or a gyrostat on its revolute joints (:mod:`xcheck.engines.mechanism`),
    with its gravity and the wheels' motors at every stage; None: a free body."""
    q0, omega0, n = fixed_step_start(INTEGRATORS, integrator, q0, omega0, dt, duration, "Drake's log is periodic")
    method, norm, error = f"drake-{integrator}", None, None
    inputs = torque is not None
    if isinstance(mechanism, Top):
        times, q, omega, error = _run_top(mechanism, integrator=integrator, q0=q0, omega0=omega0, dt=dt,
                                          duration=duration, torque=torque)
    elif mechanism is not None:
        times, q, omega, error = _run_gyrostat(mechanism, integrator=integrator, q0=q0, omega0=omega0, dt=dt,
                                               duration=duration, torque=torque)
        inputs = inputs or any(w.pulse is not None for w in mechanism.wheels)
    else:
        attitude = to_drake(q0, omega0)
        times, data = _run(inertia, mass=1.0, integrator=integrator, dt=dt, duration=duration, gravity=np.zeros(3),
                           torque=torque, state0=np.concatenate([attitude[0:4], np.zeros(3), attitude[4:7],
                                                                 np.zeros(3)]))
        k = quaternion_rows(data[:, 0:4], data[:, 0:10])
        q, omega = from_drake(np.concatenate([data[:k, 0:4], data[:k, 7:10]], axis=1))
        norm = np.linalg.norm(data[:k, 0:4], axis=1)
    traj = until_non_finite(times, q, omega, method=method, dt=dt, extras={
        "evaluations": INTEGRATORS[integrator][2] * n, "norm": norm,
        "torque_input": "at every stage" if inputs else None})
    if error is not None and traj.ok:
        traj.status, traj.message = "failed", f"{method}: Drake stopped at t = {times[-1]:.6g} s: {error}"
    return traj
