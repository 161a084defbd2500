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
from ..trajectory import Trajectory, finite_rows, fixed_step_start, until_non_finite
from .held_input import engine_torque

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
    from pydrake.multibody.tree import RotationalInertia, SpatialInertia
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import LogVectorOutput

    return SimpleNamespace(AbstractValue=AbstractValue, SpatialForce=SpatialForce,
                           ExternallyAppliedSpatialForce=ExternallyAppliedSpatialForce, MultibodyPlant=MultibodyPlant,
                           RotationalInertia=RotationalInertia, SpatialInertia=SpatialInertia,
                           ResetIntegratorFromFlags=ResetIntegratorFromFlags, Simulator=Simulator,
                           DiagramBuilder=DiagramBuilder, LeafSystem=LeafSystem, LogVectorOutput=LogVectorOutput)


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


def _torque_system(d, body_index, torque):
    """A LeafSystem whose output is ``torque(t, q, omega)`` (body components) on the body, as Drake's applied
    spatial forces, from the plant's state at each evaluation (every stage)."""

    world_torque = engine_torque(torque, form="wxyz", rates="world")

    force = d.ExternallyAppliedSpatialForce()  # one, its torque set at each evaluation (set_value copies it)
    force.body_index = body_index
    force.p_BoBq_B = np.zeros(3)
    zero = np.zeros(3)

    class Torque(d.LeafSystem):
        def __init__(self):
            super().__init__()
            self.port = self.DeclareVectorInputPort("state", 13)
            self.DeclareAbstractOutputPort("forces", lambda: d.AbstractValue.Make([d.ExternallyAppliedSpatialForce()]),
                                           self._calc)

        def _calc(self, context, output):
            x = self.port.Eval(context)
            force.F_Bq_W = d.SpatialForce(world_torque(context.get_time(), x[0:4], x[7:10]), zero)
            output.set_value([force])

    return Torque()


def _run(inertia, *, mass: float, integrator: str, state0, dt: float, duration: float, gravity, torque=None):
    """Drake's ``integrator`` at the fixed step ``dt`` on one free body (``inertia`` (3, 3) about its centre of mass,
    ``mass``) from the plant state ``state0`` ``[q_WB, p_WB, w_WB, v_WB]`` (13,) for ``duration`` s under ``gravity``,
    ``torque`` a LeafSystem's input at every stage: ``(times, states (n + 1, 13))``, logged every step."""
    d = _drake()
    I = np.asarray(inertia, dtype=float)
    builder = d.DiagramBuilder()
    plant = builder.AddSystem(d.MultibodyPlant(0.0))
    body = plant.AddRigidBody("body", d.SpatialInertia.MakeFromCentralInertia(
        float(mass), np.zeros(3), d.RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])))
    plant.mutable_gravity_field().set_gravity_vector(np.asarray(gravity, dtype=float))
    plant.Finalize()
    if torque is not None:
        source = builder.AddSystem(_torque_system(d, body.index(), torque))
        builder.Connect(plant.get_state_output_port(), source.get_input_port(0))
        builder.Connect(source.get_output_port(0), plant.get_applied_spatial_force_input_port())
    logger = d.LogVectorOutput(plant.get_state_output_port(), builder, publish_period=float(dt))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), np.asarray(state0, dtype=float))
    simulator = d.Simulator(diagram, context)
    integ = d.ResetIntegratorFromFlags(simulator, INTEGRATORS[integrator][0], float(dt))
    integ.set_fixed_step_mode(True)
    simulator.Initialize()
    simulator.AdvanceTo(float(duration))
    diagram.ForcedPublish(context)  # the end: a periodic publish at exactly the duration is not guaranteed
    log = logger.FindLog(context)
    times = np.asarray(log.sample_times(), dtype=float)
    data = np.asarray(log.data(), dtype=float).T
    keep = np.concatenate([np.diff(times) > 0.5 * dt, [True]])  # the forced publish may repeat the last sample
    return times[keep], data[keep]


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


def simulate(inertia, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None) -> Trajectory:
    """Run Drake's ``integrator`` (:data:`INTEGRATORS`) at the fixed step ``dt`` on a free body of ``inertia`` (3, 3)
    [kg m^2] from ``(q0, omega0)`` (ours) for ``duration`` s; ``torque`` None or ``(t, q, omega) -> (3,)`` [N m] in
    body components, evaluated at every stage."""
    q0, omega0, n = fixed_step_start(INTEGRATORS, integrator, q0, omega0, dt, duration, "Drake's log is periodic")
    attitude = to_drake(q0, omega0)
    times, data = _run(inertia, mass=1.0, integrator=integrator, dt=dt, duration=duration, gravity=np.zeros(3),
                       torque=torque, state0=np.concatenate([attitude[0:4], np.zeros(3), attitude[4:7], np.zeros(3)]))
    k = finite_rows(data[:, 0:10])
    q, omega = from_drake(np.concatenate([data[:k, 0:4], data[:k, 7:10]], axis=1))
    return until_non_finite(times, q, omega, method=f"drake-{integrator}", dt=dt, extras={
        "evaluations": INTEGRATORS[integrator][2] * n, "norm": np.linalg.norm(data[:k, 0:4], axis=1),
        "torque_input": "at every stage" if torque is not None else None})
