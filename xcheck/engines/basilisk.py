"""Basilisk (PyPI ``bsk``, the AVS Lab's astrodynamics framework) as a second engine: its ``Spacecraft`` hub
with one of its integrators, on the same body and initial state as every other method.

Conventions at this boundary (a test round-trips each):

* Basilisk's attitude is the MRP ``sigma_BN`` of the DCM ``[BN]``, which maps inertial (N) components to body
  (B) components: ``[BN] = quat_to_dcm(q).T``. Its Euler parameters ``beta_BN`` (scalar first) are therefore our
  ``q`` (body -> world) unchanged, and ``sigma_BN = beta_vec / (1 + beta_0)`` is :func:`xcheck.rotations.quat_to_mrp`
  of ``q`` with ``w >= 0`` (``|sigma| <= 1``, Basilisk's own set). ``omega_BN_B`` is our body rate.
* The hub's inertia ``IHubPntBc_B`` is the body-frame tensor :func:`xcheck.models.load_body` reads from the
  MJCF (centre of mass at the body origin); its mass plays no part in the attitude.

Basilisk's clock counts whole nanoseconds. A step is run as ``round(dt * 1e9)`` ns; when that is not ``dt``
exactly (1/1024 s is 976 562.5 ns) the trajectory says so (``extras["clock"]``), and it is compared with the
reference at Basilisk's own times, which it carries in ``t``. Stop times are always whole steps (a stop time
between steps would run one step too far); the run ends at the last whole step within the duration.

Torques enter through Basilisk's own modules, and Basilisk reads a module's input once per task step:

* a constant body torque: ``extForceTorque.extTorquePntB_B``, exact;
* a magnetic torque in a field given in inertial components: the ``MtbEffector`` with three torque rods along
  the body axes commanded to the permanent dipole, its ``magInMsg`` the field ``mu0 H`` at each step's midpoint
  time, held over the step. The effector rotates the field into the body with the attitude of every integrator
  stage, so the attitude dependence is integrated at the integrator's order; the field's time dependence is
  held (a midpoint rule: second order, with the field's slow rotation along the orbit as its constant). A field
  that does not change with time is written once;
* a magnetic torque in a field given in body components (a table): ``extForceTorque.cmdTorqueInMsg`` holding
  the torque at each step's midpoint time: second order;
* any other torque (a Python callable): ``extForceTorque`` set to the torque at the step's start, held: first
  order.

``extras["torque_input"]`` says which, and ``extras["input_order"]`` the order the held input leaves (None
when nothing is held). Held inputs that do not depend on the state (the field, a body-frame torque) are
computed for every step before the run and written by a compiled module ahead of the hub in its task
(:mod:`xcheck.engines.held_input`): the whole run is one call into Basilisk, with no Python per step. Only a
Python callable's torque, which needs the state, is written by a Python module at every step.

Basilisk's adaptive integrators (RKF45, RKF78) take ``rtol``: their relative tolerance, with the absolute one in
Basilisk's own proportion (its defaults: 1e-4 and 1e-8). They integrate within each task step, so ``dt`` is the
output step (and the longest step they may take, and the hold of a time-dependent input).

The simulation is built from Basilisk's ``sim_model`` directly (process, task, models), as its
``SimulationBaseClass`` does, without that module's import of matplotlib (0.8 s a process).
"""

from __future__ import annotations

import functools
from types import SimpleNamespace

import numpy as np

from .. import rotations as rot
from ..fields.kernel import MU0
from ..fields.models import ConstantTorque, MagneticTorque, SumTorque
from ..fields.orbit import GravityGradientTorque
from ..trajectory import (
    Trajectory,
    check_initial_state,
    continuous_quaternions,
    tolerances_at,
)

__all__ = ["simulate", "INTEGRATORS", "to_basilisk", "from_basilisk", "clock_step", "input_order"]

#: Our names -> Basilisk's integrator classes (``Basilisk.simulation.svIntegrators``), the ones it offers.
INTEGRATORS = {"rk4": "svIntegratorRK4", "rkf45": "svIntegratorRKF45", "rkf78": "svIntegratorRKF78"}


def to_basilisk(q, omega):
    """Our ``(q, omega)`` -> Basilisk's ``(sigma_BN, omega_BN_B)`` (``|sigma| <= 1``, quat_to_mrp's short set)."""
    return rot.quat_to_mrp(q), np.asarray(omega, dtype=float)


def from_basilisk(sigma, omega):
    """Basilisk's ``(sigma_BN, omega_BN_B)`` -> our ``(q, omega)``."""
    return rot.mrp_to_quat(sigma), np.asarray(omega, dtype=float)


def clock_step(dt: float) -> tuple[int, str | None]:
    """The step Basilisk runs for ``dt`` [s] in whole nanoseconds, and a note when it is not ``dt`` exactly."""
    exact = dt * 1e9
    ns = int(round(exact))
    if ns < 1:
        raise ValueError(f"dt: {dt:g} s is below Basilisk's clock resolution (1 ns)")
    if ns == exact:
        return ns, None
    return ns, (f"Basilisk's clock counts whole nanoseconds: the step {dt:g} s runs as {ns} ns "
                f"({abs(ns - exact) / exact:.1e} relative); compared with the reference at Basilisk's own times")


#: Basilisk's own default tolerances of its adaptive integrators (relative, absolute): an ``rtol`` keeps this
#: proportion.
DEFAULT_TOLERANCES = (1e-4, 1e-8)
ADAPTIVE = ("rkf45", "rkf78")


@functools.lru_cache(maxsize=1)
def _modules():
    from Basilisk.architecture import messaging, sim_model, sys_model_task
    from Basilisk.simulation import extForceTorque, spacecraft, svIntegrators

    return SimpleNamespace(messaging=messaging, sim_model=sim_model, sys_model_task=sys_model_task,
                           extForceTorque=extForceTorque, spacecraft=spacecraft, svIntegrators=svIntegrators)


class _Simulation:
    """One process and one task of Basilisk's ``sim_model`` (what ``SimulationBaseClass`` builds), keeping every
    object the simulation points at alive while it runs."""

    def __init__(self, ns: int):
        b = _modules()
        self.total = b.sim_model.SimModel()
        self.process = b.sim_model.SysProcess("xcheck")
        self.task = b.sys_model_task.SysModelTask(ns, 0)
        self.task.TaskName = "dynamics"
        self.process.addNewTask(self.task, -1)
        self.total.addNewProcess(self.process)
        self.keep = []
        self.wheel_speeds = None  # (recorder, number of wheels, the effector) of a gyrostat's wheels

    def add(self, model, priority: int = -1):
        """Add ``model`` to the task (a higher priority runs earlier in each task call)."""
        self.task.AddNewObject(model, priority)
        self.keep.append(model)
        return model

    def run(self, stop_ns: int) -> None:
        self.total.assignRemainingProcs()
        self.total.ResetSimulation()
        self.total.selfInitSimulation()
        self.total.resetInitSimulation()
        self.total.StepUntilStop(int(stop_ns), -1)


#: Priorities in the task: held inputs are written first, then effectors read them, then the hub integrates.
INPUT_PRIORITY, EFFECTOR_PRIORITY = 100, 50


def simulate(inertia, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None,
             rtol: float | None = None) -> Trajectory:
    """Run Basilisk's spacecraft hub with ``inertia`` (3, 3) [kg m^2] from ``(q0, omega0)`` (ours) for
    ``duration`` s at task step ``dt`` with its integrator ``integrator`` (:data:`INTEGRATORS`); ``torque``
    None, a :class:`~xcheck.fields.models.TorqueModel` or a callable ``(t, q, omega) -> (3,)``; ``rtol`` the
    relative tolerance of an adaptive integrator (None: Basilisk's default). Returns a Trajectory at Basilisk's
    own times (see the module docstring for the clock and the torque input)."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: unknown {integrator!r}; expected one of {', '.join(INTEGRATORS)}")
    if rtol is not None and integrator not in ADAPTIVE:
        raise ValueError(f"rtol: basilisk-{integrator} is a fixed-step method; a tolerance applies to "
                         f"{', '.join('basilisk-' + a for a in ADAPTIVE)}")
    tolerances = tolerances_at(rtol, DEFAULT_TOLERANCES) if integrator in ADAPTIVE else None
    q0, omega0 = check_initial_state(q0, omega0)
    ns, clock_note = clock_step(float(dt))
    n = int((round(float(duration) * 1e9)) // ns)
    if n < 1:
        raise ValueError(f"dt: {dt:g} s is longer than the duration {duration:g} s")
    b = _modules()

    sim = _Simulation(ns)
    sc = b.spacecraft.Spacecraft()
    sc.ModelTag = "xcheck-body"
    sc.hub.mHub = 1.0
    sc.hub.IHubPntBc_B = np.asarray(inertia, dtype=float).tolist()
    sigma0, w0 = to_basilisk(q0, omega0)
    sc.hub.sigma_BNInit = [[float(x)] for x in sigma0]
    sc.hub.omega_BN_BInit = [[float(x)] for x in w0]
    integ = getattr(b.svIntegrators, INTEGRATORS[integrator])(sc)
    if rtol is not None:
        integ.relTol, integ.absTol = tolerances
    sc.setIntegrator(integ)
    sim.keep.append(integ)  # SWIG objects the simulation points at must outlive it

    input_note, input_order = _torque_input(torque, sc, sim, b, ns, n)
    sim.add(sc)
    rec = sim.add(sc.scStateOutMsg.recorder())
    sim.run(n * ns)
    t = np.asarray(rec.times(), dtype=np.int64) * 1e-9
    sigma = np.asarray(rec.sigma_BN, dtype=float)
    omega = np.asarray(rec.omega_BN_B, dtype=float)
    extras = {"basilisk_version": _version(), "step_ns": ns, "clock": clock_note, "torque_input": input_note,
              "input_order": input_order, "tolerances": tolerances,
              # RK4: four evaluations of the hub's equations a step; the adaptive ones do not report theirs
              "evaluations": 4 * n if integrator == "rk4" else None}
    if getattr(sim, "wheel_speeds", None) is not None:  # a gyrostat's wheels' speeds relative to the hub
        wheel_rec, count, effector = sim.wheel_speeds
        # the effector writes its message as its task call begins, before the hub integrates the step: the row
        # recorded at t_k holds the speeds at t_(k-1) (the one before the first, the initial ones twice); the last
        # is the state the run ended with
        recorded = np.asarray(wheel_rec.wheelSpeeds, dtype=float)[:, :count]
        final = np.asarray(sc.dynManager.getStateObject(effector.nameOfReactionWheelOmegasState).getState(),
                           dtype=float).ravel()[:count]
        extras["wheel_speeds"] = np.vstack([recorded[1:], final])
    method = f"basilisk-{integrator}"
    bad = ~(np.all(np.isfinite(sigma), axis=1) & np.all(np.isfinite(omega), axis=1))
    k = int(np.argmax(bad)) if bad.any() else len(t)
    q, omega = from_basilisk(sigma[:k], omega[:k])
    traj = Trajectory(t=t[:k], q=continuous_quaternions(q) if k else np.empty((0, 4)), omega=omega, method=method,
                      dt=float(dt), extras=extras)
    if k < len(t):
        traj.status = "failed"
        traj.message = f"{method}: blew up: the state became non-finite at t = {t[k]:.6g} s"
    return traj


def _step_midpoints(ns: int, n: int) -> np.ndarray:
    """The midpoint times [s] of the steps ``k ns .. (k + 1) ns``, k < n (computed as the task call at
    ``(k + 1) ns`` sees them)."""
    h = ns * 1e-9
    return (np.arange(1, n + 1, dtype=np.int64) * ns) * 1e-9 - h + h / 2


def _held_rows(sim, message, table, ns: int):
    """A compiled module (:mod:`xcheck.engines.held_input`), ahead of everything in the task, writing row k of
    ``table`` (n, 3) into ``message``'s payload before step k."""
    from Basilisk.architecture.numbaModel import _NumbaModel

    from .held_input import write_row

    table = np.ascontiguousarray(table, dtype=float)
    meta = np.array([len(table), ns], dtype=np.int64)

    class HeldRows(_NumbaModel):
        def Reset(self, CurrentSimNanos):  # Basilisk clears the registered pointers at every reset
            _NumbaModel.Reset(self, CurrentSimNanos)
            self.addWritePayloadPtr(message.getPayloadAddress())
            self.addWriteHeaderPtr(message.getHeaderAddress())
            self.addUserPointer(meta.ctypes.data)
            self.addUserPointer(table.ctypes.data)
            self.setStateUpdateFunc(write_row.address)
            self.finalizeAllPtrs()

    module = HeldRows()
    module.ModelTag = "xcheck-held-input"
    sim.add(module, INPUT_PRIORITY)
    sim.keep += [message, table, meta]


def _before_each_step(sim, sc, step_input, ns):
    """A Basilisk Python module, ahead of the hub in the task: at the call for time ``t_k`` (the hub then
    integrates from ``t_k - h`` to ``t_k``) it calls ``step_input(t_k - h, h, sigma, omega)`` with the hub's state
    at ``t_k - h`` (its last output). Only for a torque that needs the state (a Python callable)."""
    from Basilisk.architecture import sysModel

    h = ns * 1e-9
    state = sc.scStateOutMsg

    class BeforeEachStep(sysModel.SysModel):
        def UpdateState(self, CurrentSimNanos):
            if CurrentSimNanos == 0:
                return
            out = state.read()
            step_input(CurrentSimNanos * 1e-9 - h, h, np.array(out.sigma_BN), np.array(out.omega_BN_B))

    module = BeforeEachStep()
    module.ModelTag = "xcheck-input"
    sim.add(module, INPUT_PRIORITY)


def _ext_torque(sc, sim, b):
    ext = b.extForceTorque.ExtForceTorque()
    ext.ModelTag = "xcheck-torque"
    sc.addDynamicEffector(ext)
    return sim.add(ext, EFFECTOR_PRIORITY)


#: Why a held input is second order (the note of :func:`input_order`'s 2).
MIDPOINT_NOTE = ("Basilisk reads its inputs once per step: the field is written at each step's midpoint and held over "
                 "the step (a midpoint rule in time), so its order is 2 with this field")


def input_order(kind: str | None, field=None) -> int | None:
    """The order the held input of a torque of ``kind`` (None, ``constant``, ``magnetic`` with its ``field``
    declaration or model, or any other: a Python callable) leaves in Basilisk's runs, None where nothing
    time-dependent is held: a constant, or a field fixed in time, is exact; a time-dependent field is written at
    each step's midpoint (2); a callable's torque is taken at each step's start (1). Read both where a study is
    planned (:mod:`xcheck.runners`, from the scenario's torque) and where the run is built (here)."""
    if kind in (None, "constant", "solar-pressure", "gravity-gradient"):  # a force fixed in the world, written
        return None  # once; the gravity gradient by Basilisk's own effector at every stage
    if kind in ("aerodynamic", "motor-pulse"):  # a force that turns with the orbit, a wheel's motor pulse: written
        return 2  # at each step's midpoint
    if kind == "magnetic":
        return 2 if field.time_dependent else None
    return 1


def _torque_input(torque, sc, sim, b, ns: int, n: int):
    """Connect ``torque`` to the hub (modules added to ``sim``). Returns ``(note, order)``: how it enters, and the
    order its holding leaves (None: nothing held)."""
    if torque is None:
        return "none (torque free)", None
    if isinstance(torque, SumTorque):  # each term through its own effector; the order the lowest they leave
        inputs = [_torque_input(term, sc, sim, b, ns, n) for term in torque.terms]
        orders = [order for _, order in inputs if order is not None]
        return " + ".join(note for note, _ in inputs), (min(orders) if orders else None)
    if getattr(torque, "conserves_momentum", False):  # a gyrostat's wheels: Basilisk's own effector is their model
        return _reaction_wheels(torque, sc, sim, ns, n)
    if isinstance(torque, GravityGradientTorque):
        return _gravity_gradient(torque, sc, sim)
    if isinstance(torque, ConstantTorque):
        ext = _ext_torque(sc, sim, b)
        ext.extTorquePntB_B = [[float(x)] for x in torque.P]
        return "extForceTorque.extTorquePntB_B (constant)", None
    if isinstance(torque, MagneticTorque) and torque.field.frame == "world":
        return _mtb(torque, sc, sim, b, ns, n)
    ext = _ext_torque(sc, sim, b)
    if isinstance(torque, MagneticTorque):  # a body-frame field: attitude-independent, time-dependent
        message = b.messaging.CmdTorqueBodyMsg()
        ext.cmdTorqueInMsg.subscribeTo(message)
        t = _step_midpoints(ns, n)
        _held_rows(sim, message, torque.many(t, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3)), ns)
        return ("extForceTorque.cmdTorqueInMsg: the torque at each step's midpoint, held over the step",
                input_order("magnetic", torque.field))

    def step_input(t, h, sigma, omega):
        ext.extTorquePntB_B = [[float(x)] for x in np.asarray(torque(t, rot.mrp_to_quat(sigma), omega), float)]
    _before_each_step(sim, sc, step_input, ns)
    return "extForceTorque, set before every step to the torque at the step's start, held", input_order("callable")


def _gravity_gradient(torque, sc, sim):
    """The gravity gradient as Basilisk's own ``GravityGradientEffector`` (issue 28): the spacecraft flies the same
    circular orbit inside Basilisk (a point-mass Earth of our mu, the orbit's position and velocity at t = 0), and
    the effector takes its position, attitude and whole inertia at every stage of the integrator: nothing held."""
    from Basilisk.simulation import GravityGradientEffector
    from Basilisk.utilities import simIncludeGravBody

    from ..fields.kernel import orbit_direction, orbit_velocity_direction
    from ..fields.orbit import MU_EARTH

    _, n, inc, raan, u0 = torque.P[9:14]
    sc.hub.r_CN_NInit = [[float(torque.a * x)] for x in orbit_direction(n, inc, raan, u0, 0.0)]
    sc.hub.v_CN_NInit = [[float(torque.a * n * x)] for x in orbit_velocity_direction(n, inc, raan, u0, 0.0)]
    gravity = simIncludeGravBody.gravBodyFactory()
    earth = gravity.createCustomGravObject("earth", MU_EARTH)
    earth.isCentralBody = True
    gravity.addBodiesTo(sc)
    effector = GravityGradientEffector.GravityGradientEffector()
    effector.ModelTag = "xcheck-gravity-gradient"
    effector.addPlanetName(earth.planetName)
    sc.addDynamicEffector(effector)
    sim.add(effector, EFFECTOR_PRIORITY)
    sim.keep += [gravity, earth]
    return ("GravityGradientEffector on the same circular orbit flown inside Basilisk (a point-mass Earth), at every "
            "stage"), None


def _reaction_wheels(wheels, sc, sim, ns: int, n: int):
    """A gyrostat's free wheels as Basilisk's own (issue 28): ``ReactionWheelStateEffector`` with balanced wheels
    on the hub, each its spin axis, axial moment ``Js`` and initial speed relative to the hub. Basilisk leaves a
    balanced wheel's mass and inertia to the hub's (its issue 600), so the hub's inertia is the whole body's,
    ours plus each wheel's axial moment; its equations take the axial spin back out (the gyrostat's). The wheels'
    speeds are integrated as Basilisk states, in every stage. A motor's pulse is its command in
    ``rwMotorCmdInMsg``, written at each step's midpoint and held over the step (a midpoint rule: order 2), by the
    compiled held-input module; three wheels at most carry one."""
    from Basilisk.architecture import messaging
    from Basilisk.simulation import reactionWheelStateEffector

    commanded = [k for k, wheel in enumerate(wheels.wheels) if wheel[3] is not None]
    if any(k >= 3 for k in commanded):
        raise ValueError("Basilisk: a motor pulse on a fourth wheel is not driven (the held input writes three "
                         "commands); order the MJCF's wheels with the motors first")
    hub = np.array(sc.hub.IHubPntBc_B, dtype=float)
    effector = reactionWheelStateEffector.ReactionWheelStateEffector()
    effector.ModelTag = "xcheck-wheels"
    w0 = np.array(sc.hub.omega_BN_BInit, dtype=float).ravel()
    for k, (axis, moment, p0, _) in enumerate(wheels.wheels):
        a = np.asarray(axis, dtype=float)
        rw = reactionWheelStateEffector.RWConfigPayload()
        rw.label = f"W{k + 1}"
        rw.RWModel = messaging.BalancedWheels
        rw.Js, rw.Jt, rw.Jg = float(moment), 0.5 * float(moment), 0.5 * float(moment)
        rw.gsHat_B = [[float(x)] for x in a]
        frame = rot.frame_with_z(a)  # the wheel's transverse axes (a balanced wheel's are immaterial)
        rw.w2Hat0_B = [[float(x)] for x in frame[:, 0]]
        rw.w3Hat0_B = [[float(x)] for x in frame[:, 1]]
        rw.rWB_B = [[0.0], [0.0], [0.0]]
        rw.Omega = float(p0 / moment - a @ w0)  # [rad/s], relative to the hub
        rw.theta = 0.0
        rw.u_max = -1.0  # no torque saturation, no friction, no speed limit
        rw.u_min = 0.0
        rw.fCoulomb = 0.0
        rw.Omega_max = -1.0
        rw.P_max = -1.0
        rw.betaStatic = -1.0
        effector.addReactionWheel(rw)
        hub = hub + moment * np.outer(a, a)
        sim.keep.append(rw)
    sc.hub.IHubPntBc_B = hub.tolist()
    sc.addStateEffector(effector)
    sim.add(effector, EFFECTOR_PRIORITY)
    sim.wheel_speeds = (sim.add(effector.rwSpeedOutMsg.recorder()), len(wheels.wheels), effector)
    note = (f"ReactionWheelStateEffector: {len(wheels.wheels)} balanced wheel(s), their speeds Basilisk states (the "
            "hub's inertia the whole body's)")
    if not commanded:
        return note, None
    t = _step_midpoints(ns, n)
    table = np.zeros((n, 3))
    _, pulses = wheels._pulses(t)  # each command's value at each step's midpoint, in the wheels' order
    for k in commanded:
        table[:, k] = pulses[:, wheels.wheels[k][3]]
    message = messaging.ArrayMotorTorqueMsg()
    effector.rwMotorCmdInMsg.subscribeTo(message)
    _held_rows(sim, message, table, ns)
    return (note + "; the motors' pulses in rwMotorCmdInMsg at each step's midpoint, held over the step",
            input_order("motor-pulse"))


def _mtb(torque, sc, sim, b, ns: int, n: int):
    """The permanent dipole as three torque rods along the body axes in Basilisk's ``MtbEffector``, the field
    ``mu0 H_world`` in its ``magInMsg`` (at each step's midpoint time; once for a field fixed in time)."""
    from Basilisk.simulation import MtbEffector

    messaging = b.messaging
    mtb = MtbEffector.MtbEffector()
    mtb.ModelTag = "xcheck-dipole"
    params = messaging.MTBArrayConfigMsgPayload()
    params.numMTB = 3
    params.GtMatrix_B = np.eye(3).flatten().tolist()
    dipole = np.asarray(torque.dipole, dtype=float)
    params.maxMtbDipoles = [float(np.abs(dipole).max() * 2 + 1.0)] * 3
    params_msg = messaging.MTBArrayConfigMsg().write(params)
    cmd = messaging.MTBCmdMsgPayload()
    cmd.mtbDipoleCmds = dipole.tolist()
    cmd_msg = messaging.MTBCmdMsg().write(cmd)
    field_msg = messaging.MagneticFieldMsg()
    field = torque.field
    field_payload = messaging.MagneticFieldMsgPayload()
    field_payload.magField_N = (MU0 * np.asarray(field.strength(np.array([0.0]))[0], dtype=float)).tolist()
    field_msg.write(field_payload)
    mtb.mtbCmdInMsg.subscribeTo(cmd_msg)
    mtb.mtbParamsInMsg.subscribeTo(params_msg)
    mtb.magInMsg.subscribeTo(field_msg)
    sc.addDynamicEffector(mtb)
    sim.add(mtb, EFFECTOR_PRIORITY)
    sim.keep += [params_msg, cmd_msg, field_msg, field_payload]
    if not field.time_dependent:
        return "MtbEffector (the dipole as three torque rods), the field in magInMsg (fixed in time)", None
    _held_rows(sim, field_msg, MU0 * np.asarray(field.strength(_step_midpoints(ns, n)), dtype=float), ns)
    return ("MtbEffector (the dipole as three torque rods; the attitude of every stage), the field in magInMsg at "
            "each step's midpoint time, held over the step", input_order("magnetic", field))


@functools.lru_cache(maxsize=1)
def _version() -> str | None:
    from ..base.packages import package_version

    return package_version("bsk")
