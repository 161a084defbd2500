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
  the body axes commanded to the permanent dipole, its ``magInMsg`` the field ``mu0 H`` written before every
  step at the step's midpoint time and held over the step. The effector rotates the field into the body with
  the attitude of every integrator stage, so the attitude dependence is integrated at the integrator's order;
  the field's time dependence is held (a midpoint rule: second order, with the field's slow rotation along
  the orbit as its constant). A uniform field is written once;
* a magnetic torque in a field given in body components (a table): ``extForceTorque`` set before every step to
  the torque at the step's midpoint time, held: second order;
* any other torque (a Python callable): ``extForceTorque`` set to the torque at the step's start, held: first
  order.

``extras["torque_input"]`` says which, and ``extras["input_order"]`` the order the held input leaves (None
when nothing is held). What changes between steps is written by a Python module (a Basilisk ``SysModel``) that
runs ahead of the hub in the same task: the whole run is one ``ExecuteSimulation``.
"""

from __future__ import annotations

import numpy as np

from .. import rotations as rot
from ..fields.models import ConstantTorque, MagneticTorque
from ..trajectory import Trajectory, check_initial_state, continuous_quaternions

__all__ = ["simulate", "INTEGRATORS", "to_basilisk", "from_basilisk", "clock_step"]

#: Our names -> Basilisk's integrator classes (``Basilisk.simulation.svIntegrators``), the ones it offers.
INTEGRATORS = {"rk4": "svIntegratorRK4", "rkf45": "svIntegratorRKF45", "rkf78": "svIntegratorRKF78"}
MU0 = 4e-7 * np.pi


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


def _modules():
    from Basilisk.architecture import messaging
    from Basilisk.simulation import extForceTorque, spacecraft, svIntegrators
    from Basilisk.utilities import SimulationBaseClass

    return messaging, extForceTorque, spacecraft, svIntegrators, SimulationBaseClass


def simulate(inertia, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None) -> Trajectory:
    """Run Basilisk's spacecraft hub with ``inertia`` (3, 3) [kg m^2] from ``(q0, omega0)`` (ours) for
    ``duration`` s at task step ``dt`` with its integrator ``integrator`` (:data:`INTEGRATORS`); ``torque``
    None, a :class:`~xcheck.fields.models.TorqueModel` or a callable ``(t, q, omega) -> (3,)``. Returns a
    Trajectory at Basilisk's own times (see the module docstring for the clock and the torque input)."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: unknown {integrator!r}; expected one of {', '.join(INTEGRATORS)}")
    q0, omega0 = check_initial_state(q0, omega0)
    ns, clock_note = clock_step(float(dt))
    n = int((round(float(duration) * 1e9)) // ns)
    if n < 1:
        raise ValueError(f"dt: {dt:g} s is longer than the duration {duration:g} s")
    messaging, extForceTorque, spacecraft, svIntegrators, SimulationBaseClass = _modules()

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("xcheck")
    proc.addTask(sim.CreateNewTask("dynamics", ns))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "xcheck-body"
    sc.hub.mHub = 1.0
    sc.hub.IHubPntBc_B = np.asarray(inertia, dtype=float).tolist()
    sigma0, w0 = to_basilisk(q0, omega0)
    sc.hub.sigma_BNInit = [[float(x)] for x in sigma0]
    sc.hub.omega_BN_BInit = [[float(x)] for x in w0]
    integ = getattr(svIntegrators, INTEGRATORS[integrator])(sc)
    sc.setIntegrator(integ)
    sim.AddModelToTask("dynamics", sc)
    keep = [integ]  # SWIG objects the simulation points at must outlive it

    step_input, input_note, input_order = _torque_input(torque, sc, sim, keep, messaging, extForceTorque)
    if step_input is not None:  # a Python module that runs before the hub at every task call
        keep.append(_before_each_step(sim, sc, step_input, ns))
    rec = sc.scStateOutMsg.recorder()
    sim.AddModelToTask("dynamics", rec)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(n * ns)
    sim.ExecuteSimulation()
    t = np.asarray(rec.times(), dtype=np.int64) * 1e-9
    sigma = np.asarray(rec.sigma_BN, dtype=float)
    omega = np.asarray(rec.omega_BN_B, dtype=float)
    extras = {"basilisk_version": _version(), "step_ns": ns, "clock": clock_note, "torque_input": input_note,
              "input_order": input_order}
    method = f"basilisk-{integrator}"
    bad = ~(np.all(np.isfinite(sigma), axis=1) & np.all(np.isfinite(omega), axis=1))
    k = int(np.argmax(bad)) if bad.any() else len(t)
    q, omega = from_basilisk(sigma[:k], omega[:k])
    traj = Trajectory(t=t[:k], q=continuous_quaternions(q) if k else np.empty((0, 4)), omega=omega, method=method,
                      dt=float(dt), extras=extras)
    if k < len(t):
        traj.status = "failed"
        traj.message = f"{method}: the state became non-finite at t = {t[k]:.6g} s"
    return traj


def _before_each_step(sim, sc, step_input, ns):
    """A Basilisk Python module, ahead of the hub in the task: at the call for time ``t_k`` (the hub then
    integrates from ``t_k - h`` to ``t_k``) it calls ``step_input(t_k - h, h, sigma, omega)`` with the hub's state
    at ``t_k - h`` (its last output). One ``ExecuteSimulation`` for the whole run."""
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
    sim.AddModelToTask("dynamics", module, 100)  # a higher priority runs first
    return module


def _torque_input(torque, sc, sim, keep, messaging, extForceTorque):
    """Connect ``torque`` to the hub. Returns ``(step_input, note, order)``: ``step_input(t, h, sigma, omega)``
    called before every step from ``t`` to ``t + h`` (None when nothing changes between steps)."""
    if torque is None:
        return None, "none (torque free)", None
    if isinstance(torque, ConstantTorque):
        ext = extForceTorque.ExtForceTorque()
        ext.extTorquePntB_B = [[float(x)] for x in torque.P]
        sc.addDynamicEffector(ext)
        sim.AddModelToTask("dynamics", ext)
        keep.append(ext)
        return None, "extForceTorque.extTorquePntB_B (constant)", None
    if isinstance(torque, MagneticTorque) and torque.field.frame == "world":
        return _mtb(torque, sc, sim, keep, messaging)
    ext = extForceTorque.ExtForceTorque()
    sc.addDynamicEffector(ext)
    sim.AddModelToTask("dynamics", ext)
    keep.append(ext)
    if isinstance(torque, MagneticTorque):  # a body-frame field: attitude-independent, time-dependent
        def step_input(t, h, sigma, omega):
            ext.extTorquePntB_B = [[float(x)] for x in torque(t + h / 2, np.array([1.0, 0, 0, 0]), omega)]
        return step_input, "extForceTorque, set before every step to the torque at the step's midpoint, held", 2

    def step_input(t, h, sigma, omega):
        ext.extTorquePntB_B = [[float(x)] for x in np.asarray(torque(t, rot.mrp_to_quat(sigma), omega), float)]
    return step_input, "extForceTorque, set before every step to the torque at the step's start, held", 1


def _mtb(torque, sc, sim, keep, messaging):
    """The permanent dipole as three torque rods along the body axes in Basilisk's ``MtbEffector``, the field
    ``mu0 H_world`` in its ``magInMsg`` (written at each step's midpoint time; once for a uniform field)."""
    from Basilisk.simulation import MtbEffector

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
    field_payload = messaging.MagneticFieldMsgPayload()
    field_msg = messaging.MagneticFieldMsg()
    field = torque.field

    def write_field(t):
        field_payload.magField_N = (MU0 * np.asarray(field.strength(np.array([t]))[0], dtype=float)).tolist()
        field_msg.write(field_payload)

    write_field(0.0)
    mtb.mtbCmdInMsg.subscribeTo(cmd_msg)
    mtb.mtbParamsInMsg.subscribeTo(params_msg)
    mtb.magInMsg.subscribeTo(field_msg)
    sc.addDynamicEffector(mtb)
    sim.AddModelToTask("dynamics", mtb)
    keep += [mtb, params_msg, cmd_msg, field_msg, field_payload]
    if field.name == "uniform":
        return None, "MtbEffector (the dipole as three torque rods), uniform field in magInMsg", None

    def step_input(t, h, sigma, omega):
        write_field(t + h / 2)
    return (step_input, "MtbEffector (the dipole as three torque rods; the attitude of every stage), the field "
            "in magInMsg written at each step's midpoint time and held over the step", 2)


def _version() -> str | None:
    from ..versions import package_version

    return package_version("bsk")
