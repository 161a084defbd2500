"""EXUDYN (PyPI ``exudyn``) as an engine (issue 40): one rigid body on a ``NodeRigidBodyRotVecLG`` (a rotation vector
updated by Lie group methods: Holzinger and Gerstmayr's formulation, the literature the seed 004 method comes from),
run by EXUDYN's own solvers at a fixed step (:data:`INTEGRATORS`): its explicit Lie group Runge-Kutta methods
(``timeIntegration.explicitIntegration.useLieGroupIntegration``) and its implicit generalized-alpha and trapezoidal
(index-2) solvers. The whole run is one C++ call; sensors stored in memory give the state at every step.

Conventions at this boundary (tested both ways): the node's rotation coordinates are the rotation vector of our
``R`` (body -> world: its ``RotationMatrix`` output maps local to global), entered as the reference coordinates; its
rotation velocity coordinates are the body-frame angular velocity (the Lie group node's ``G`` is the identity), our
``omega`` as it is; it reads back ``RotationMatrix`` (row-major) and ``AngularVelocityLocal``. The inertia is the
body-frame tensor, products included (``inertia = [Ixx, Iyy, Izz, Iyz, Ixz, Ixy]``); EXUDYN applies no gravity
unless given a load.

The torque is a ``LoadTorqueVector`` with a user function EXUDYN calls at every stage (and every Newton iteration of
an implicit solver), in world components from the stage's state (compiled:
:func:`xcheck.engines.held_input.engine_torque`): the explicit methods keep their orders under an attitude-dependent
torque. Its Python call a stage is the run's cost then (tens of microseconds a stage, where a torque-free step is 1-2).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np

from .. import rotations as rot
from ..trajectory import Trajectory, finite_rows, fixed_step_start, until_non_finite
from .held_input import engine_torque
from .mechanism import Top

__all__ = ["simulate", "free_flight", "INTEGRATORS", "to_exudyn", "from_exudyn", "cannot", "EXPLICIT_TOP", "GYROSTAT"]

#: The implicit solvers' Newton tolerance, relative and absolute (EXUDYN's defaults 1e-8 and 1e-10 leave a floor
#: near 1e-8 rad under a torque)
NEWTON_TOLERANCE = 1e-13
#: Our names -> (EXUDYN's DynamicSolverType, order, right-hand-side evaluations a step (None: iterated)).
INTEGRATORS = {"explicit-euler": ("ExplicitEuler", 1, 1), "explicit-midpoint": ("ExplicitMidpoint", 2, 2),
               "rk44": ("RK44", 4, 4), "rk67": ("RK67", 6, 9), "generalized-alpha": ("GeneralizedAlpha", 2, None),
               "trapezoidal-index2": ("TrapezoidalIndex2", 2, None)}


@functools.lru_cache(maxsize=1)
def _exudyn():
    """EXUDYN and its item interface, imported once."""
    import exudyn
    from exudyn import itemInterface

    return exudyn, itemInterface


def to_exudyn(q, omega) -> tuple[np.ndarray, np.ndarray]:
    """Our ``(q, omega)`` -> the node's ``(rotation vector of R, rotation velocities = body rate)``."""
    return rot.quat_to_rotvec(np.asarray(q, dtype=float)), np.asarray(omega, dtype=float)


def from_exudyn(R_rows, omega_local) -> tuple[np.ndarray, np.ndarray]:
    """EXUDYN's ``RotationMatrix`` rows (9, row-major, body -> world) and ``AngularVelocityLocal`` -> ``(q, omega)``."""
    R = np.asarray(R_rows, dtype=float).reshape(-1, 3, 3)
    return rot.dcm_to_quat(R), np.asarray(omega_local, dtype=float).reshape(-1, 3)


#: Why EXUDYN's explicit solvers run no top (its theory docs, "Constraints with explicit solvers"): they solve no
#: joint constraint, and a ground ``CoordinateConstraint`` they eliminate by setting the coordinate and its rate to
#: zero after each evaluation, not by removing it from the equations: a top's pivot so fixed leaves its rotation that
#: of a free body about its centre of mass (0.59 rad off the heavy top in 1 s, measured).
EXPLICIT_TOP = ("EXUDYN's explicit solvers fix a pivot by zeroing its coordinates after each evaluation "
                "(explicit.eliminateConstraints), so a top turns as a free body about its centre of mass (0.59 rad "
                "off in 1 s); its implicit solvers run it on a ball joint")
#: Why no EXUDYN solver runs a gyrostat here: a wheel is a second body joined by a revolute joint, an algebraic
#: constraint. Its explicit solvers solve none; its implicit ones iterate Newton on it at every step (0.1-0.2 ms a
#: step), fail at the tumbler's coarse steps (1/64 s), and took a minute for one quick study (measured, 1.13.6).
GYROSTAT = ("EXUDYN's wheels are bodies on revolute-joint constraints: its explicit solvers solve none, and its "
            "implicit solvers' Newton iterations fail at coarse steps and take a minute a quick study; xcheck does "
            "not run gyrostats in EXUDYN")


def cannot(integrator: str, mechanism) -> str | None:
    """Why EXUDYN's ``integrator`` cannot run the body ``mechanism`` (:func:`xcheck.engines.mechanism.mechanism_of`, or
    its class), or None: a top on its implicit solvers only (:data:`EXPLICIT_TOP`), a gyrostat on none
    (:data:`GYROSTAT`)."""
    if mechanism is None:
        return None
    if not (mechanism is Top or isinstance(mechanism, Top)):
        return GYROSTAT
    return EXPLICIT_TOP if INTEGRATORS[integrator][2] is not None else None


def _inertia6(I) -> list:
    """A tensor as EXUDYN's ``[Ixx, Iyy, Izz, Iyz, Ixz, Ixy]``."""
    I = np.asarray(I, dtype=float)
    return [I[0, 0], I[1, 1], I[2, 2], I[1, 2], I[0, 2], I[0, 1]]


def _top(mbs, items, top, rv0, w0) -> int:
    """A top in EXUDYN: its node at the pivot (the world's origin), the centre of mass ``top.centre`` from it and the
    inertia about the pivot (EXUDYN's rigid body takes it about its reference point), the node's position held at the
    origin by three ground ``CoordinateConstraint`` objects (a ball joint), gravity a mass-proportional load. The
    node."""
    node = mbs.AddNode(items.NodeRigidBodyRotVecLG(referenceCoordinates=[0.0, 0.0, 0.0, *map(float, rv0)],
                                                   initialVelocities=[0.0, 0.0, 0.0, *map(float, w0)]))
    body = mbs.AddObject(items.ObjectRigidBody(mass=float(top.mass), nodeNumber=node,
                                               inertia=_inertia6(top.about_pivot),
                                               centerOfMass=list(map(float, top.centre))))
    ground = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(items.NodePointGround()), coordinate=0))
    for i in range(3):
        mbs.AddObject(items.CoordinateConstraint(markerNumbers=[
            ground, mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=node, coordinate=i))]))
    mbs.AddLoad(items.LoadMassProportional(markerNumber=mbs.AddMarker(items.MarkerBodyMass(bodyNumber=body)),
                                           loadVector=list(map(float, top.gravity))))
    return node


def free_flight(*, integrator: str, mass: float, moments, omega0, v0, gravity, dt: float, nsteps: int):
    """EXUDYN's ``integrator`` flying a body whole, translation and gravity included, as the boxes benchmark does
    (:mod:`xcheck.league`): one Lie group node, principal ``moments`` along the body axes, the identity attitude at
    the origin, ``v0`` [m/s] and ``omega0`` [rad/s] (body and world components alike at the identity), gravity a
    mass-proportional load, ``nsteps`` steps of ``dt`` in one C++ call. Returns ``(t, c, q, v, omega)`` like
    :func:`xcheck.engines.mujoco.free_flight` (omega in body components)."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: unknown {integrator!r}; expected one of {', '.join(INTEGRATORS)}")
    exu, items = _exudyn()
    mbs = exu.SystemContainer().AddSystem()
    node = mbs.AddNode(items.NodeRigidBodyRotVecLG(referenceCoordinates=[0.0] * 6,
                                                   initialVelocities=[*map(float, v0), *map(float, omega0)]))
    body = mbs.AddObject(items.ObjectRigidBody(mass=float(mass), nodeNumber=node,
                                               inertia=_inertia6(np.diag(np.asarray(moments, dtype=float)))))
    mbs.AddLoad(items.LoadMassProportional(markerNumber=mbs.AddMarker(items.MarkerBodyMass(bodyNumber=body)),
                                           loadVector=list(map(float, gravity))))
    kinds = (exu.OutputVariableType.Position, exu.OutputVariableType.Velocity, exu.OutputVariableType.RotationMatrix,
             exu.OutputVariableType.AngularVelocityLocal)
    sensors = [mbs.AddSensor(items.SensorNode(nodeNumber=node, storeInternal=True, outputVariableType=kind))
               for kind in kinds]
    mbs.Assemble()
    _solve(exu, mbs, integrator, n=int(nsteps), dt=float(dt), duration=int(nsteps) * float(dt))
    c, v, R, w = (np.asarray(mbs.GetSensorStoredData(s), dtype=float) for s in sensors)
    q, omega = from_exudyn(R[:, 1:], w[:, 1:])
    return c[:, 0], c[:, 1:], q, v[:, 1:], omega


def _solve(exu, mbs, integrator: str, *, n: int, dt: float, duration: float) -> None:
    """Run EXUDYN's ``integrator`` on the assembled ``mbs``: ``n`` steps to ``duration``, every step's sensor values
    stored, the implicit solvers' Newton to :data:`NEWTON_TOLERANCE`. EXUDYN's own errors propagate."""
    settings = exu.SimulationSettings()
    with warnings.catch_warnings():  # 1.13 warns on the settings' older names, which it still reads
        warnings.simplefilter("ignore", DeprecationWarning)
        settings.timeIntegration.numberOfSteps = n
        settings.timeIntegration.endTime = duration
        settings.timeIntegration.verboseMode = 0
        settings.timeIntegration.explicitIntegration.useLieGroupIntegration = True
        settings.solutionSettings.writeSolutionToFile = False
        settings.solutionSettings.sensorsWritePeriod = dt
        settings.displayComputationTime = False
        settings.displayStatistics = False
    # the implicit solvers' Newton iterations to round-off: at EXUDYN's defaults (relative 1e-8, absolute 1e-10) their
    # error stops near 1e-8 rad on RAX-1's field table, which read as an order of 0.88 at fine steps
    settings.timeIntegration.newton.relativeTolerance = NEWTON_TOLERANCE
    settings.timeIntegration.newton.absoluteTolerance = NEWTON_TOLERANCE
    exu.SolveDynamic(mbs, simulationSettings=settings, solverType=getattr(exu.DynamicSolverType,
                                                                          INTEGRATORS[integrator][0]))


def simulate(inertia, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None,
             mechanism=None) -> Trajectory:
    """Run EXUDYN's ``integrator`` (:data:`INTEGRATORS`) at the fixed step ``dt`` on a free body of ``inertia`` (3, 3)
    [kg m^2] from ``(q0, omega0)`` (ours) for ``duration`` s; ``torque`` None or ``(t, q, omega) -> (3,)`` [N m] in
    body components, evaluated at every stage. ``mechanism``: a top (:mod:`xcheck.engines.mechanism`; the implicit
    solvers, :func:`cannot`) on EXUDYN's own constraints, with its gravity; None: a free body."""
    why = cannot(integrator, mechanism) if integrator in INTEGRATORS else None
    if why is not None:
        raise ValueError(f"integrator: {why}")
    return _simulate(inertia, integrator=integrator, q0=q0, omega0=omega0, dt=dt, duration=duration, torque=torque,
                     mechanism=mechanism)


def _simulate(inertia, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None,
              mechanism=None) -> Trajectory:
    """:func:`simulate` without asking :func:`cannot` (what the findings' tests run)."""
    q0, omega0, n = fixed_step_start(INTEGRATORS, integrator, q0, omega0, dt, duration, "EXUDYN takes equal steps")
    exu, items = _exudyn()
    mbs = exu.SystemContainer().AddSystem()
    rv0, w0 = to_exudyn(q0, omega0)
    if isinstance(mechanism, Top):
        node = _top(mbs, items, mechanism, rv0, w0)
    else:
        I = np.asarray(inertia, dtype=float)
        node = mbs.AddNode(items.NodeRigidBodyRotVecLG(referenceCoordinates=[0.0, 0.0, 0.0, *map(float, rv0)],
                                                       initialVelocities=[0.0, 0.0, 0.0, *map(float, w0)]))
        mbs.AddObject(items.ObjectRigidBody(mass=1.0, nodeNumber=node, inertia=_inertia6(I)))
    if torque is not None:
        world_torque = engine_torque(torque, form="dcm", rates="body")
        current = exu.ConfigurationType.Current
        R_out, w_out = exu.OutputVariableType.RotationMatrix, exu.OutputVariableType.AngularVelocityLocal

        def load(mbs_, t, _):  # the stage's state, as the solver evaluates it
            R = np.asarray(mbs_.GetNodeOutput(node, R_out, configuration=current), dtype=float)
            w = np.asarray(mbs_.GetNodeOutput(node, w_out, configuration=current), dtype=float)
            return world_torque(t, R, w).tolist()
        marker = mbs.AddMarker(items.MarkerNodeRigid(nodeNumber=node))
        mbs.AddLoad(items.LoadTorqueVector(markerNumber=marker, loadVector=[0.0, 0.0, 0.0], bodyFixed=False,
                                           loadVectorUserFunction=load))
    sensors = [mbs.AddSensor(items.SensorNode(nodeNumber=node, storeInternal=True, outputVariableType=kind))
               for kind in (exu.OutputVariableType.RotationMatrix, exu.OutputVariableType.AngularVelocityLocal)]
    mbs.Assemble()
    _, _, evaluations = INTEGRATORS[integrator]
    method = f"exudyn-{integrator}"
    try:
        _solve(exu, mbs, integrator, n=n, dt=float(dt), duration=float(duration))
    except Exception as exc:  # EXUDYN raises its own errors for a solver that does not converge
        return Trajectory(t=np.zeros(0), q=np.empty((0, 4)), omega=np.empty((0, 3)), method=method, dt=float(dt),
                          status="failed", message=f"{method}: EXUDYN's solver failed: {exc}")
    R_data, w_data = (np.asarray(mbs.GetSensorStoredData(s), dtype=float) for s in sensors)
    t, k = R_data[:, 0], finite_rows(R_data, w_data)
    q, omega = from_exudyn(R_data[:k, 1:], w_data[:k, 1:])
    traj = until_non_finite(t, q, omega, method=method, dt=dt, extras={
        "evaluations": None if evaluations is None else evaluations * n,
        "torque_input": "at every stage" if torque is not None else None})
    if traj.ok and (k != n + 1 or abs(t[-1] - duration) > 1e-9 * max(duration, 1.0)):
        traj.status, traj.message = "failed", (f"{method}: EXUDYN stored {k} samples to t = {t[-1]:.6g} s, expected "
                                               f"{n + 1} to {duration:g} s")
    return traj
