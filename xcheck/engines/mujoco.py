"""MuJoCo as a runner: the same body, initial state and torque as our integrators, MuJoCo's integrators.

* The state goes in and comes out through ``qpos``/``qvel`` (free joint: quaternion [w, x, y, z] body ->
  world, angular velocity in the body frame), never ``xmat``/``xquat``, which still hold the pose from
  before the last ``mj_step``.
* A torque is applied inside MuJoCo's control callback, which MuJoCo calls at every stage of its RK4
  with that stage's ``qpos``, ``qvel`` and ``time``: RK4 keeps its order 4 with an attitude-dependent
  torque. It is written to ``qfrc_applied`` of the free joint's rotational dofs (body-frame torque).
  ``torque_mode="held"`` instead writes it once per step to ``xfrc_applied`` (the naive way, held over
  the step) to show what that costs.
* The callback is process-global: :func:`control_callback` installs and restores it. Parallel runs must
  use processes, not threads.
* Runs use :func:`mujoco.rollout.rollout` (one C call for the whole run), with the torque in the control callback
  (which ``rollout``'s ``mj_step`` calls as a Python loop's would); only a held torque needs a Python loop.
* A blow-up is a failed run, in MuJoCo's own words: MuJoCo's warnings ("Nan, Inf or huge value in QVEL ...")
  are collected during the run (:func:`mujoco_warnings`), and its automatic reset to the initial pose is
  switched off so that the trajectory ends at the last good step instead of restarting from rest.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

from .. import rotations as rot
from ..fields import TorqueModel, torque_eval
from ..models import MJCFBody, load_mujoco
from ..trajectory import (
    Trajectory,
    check_initial_state,
    continuous_quaternions,
    step_plan,
    time_grid,
)

__all__ = ["simulate", "free_flight", "control_callback", "mujoco_warnings", "INTEGRATORS"]

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}


@contextmanager
def control_callback(callback):
    """Install ``callback(model, data)`` as MuJoCo's process-global control callback; restore the
    previous one on exit (also on error)."""
    previous = mujoco.get_mjcb_control()
    mujoco.set_mjcb_control(callback)
    try:
        yield
    finally:
        mujoco.set_mjcb_control(previous)


@contextmanager
def mujoco_warnings():
    """Collect MuJoCo's warning messages (a list, filled during the block) instead of printing them;
    MuJoCo's warning handler is process-global and restored on exit."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


#: MuJoCo's bound on a sane qpos/qvel/qacc entry (``mjMAXVAL``): beyond it MuJoCo calls the state unstable.
MJ_MAXVAL = 1e10


def _first_bad_row(qpos, qvel):
    """Index of the first row that is non-finite or beyond :data:`MJ_MAXVAL`, or None."""
    bad = ~np.all(np.isfinite(qpos) & (np.abs(qpos) <= MJ_MAXVAL), axis=1) | \
        ~np.all(np.isfinite(qvel) & (np.abs(qvel) <= MJ_MAXVAL), axis=1)
    return int(np.argmax(bad)) if np.any(bad) else None


def _prepare(model) -> tuple[mujoco.MjModel, MJCFBody]:
    if isinstance(model, (str, Path)):
        return load_mujoco(model)
    if isinstance(model, MJCFBody):
        return load_mujoco(model.path)
    raise ValueError(f"model: expected an MJCF path or an MJCFBody, got {type(model).__name__}")


_MODELS: dict = {}


def _model_for_runs(model, inertia_moments) -> tuple[mujoco.MjModel, MJCFBody]:
    """The compiled model a run uses, kept per process for its file (unchanged) and inertia: every run sets the
    options it depends on (integrator, step, flags), so that runs share it instead of compiling the MJCF each time
    (a study runs MuJoCo hundreds of times)."""
    if not isinstance(model, (str, Path, MJCFBody)):
        return _with_moments(*_prepare(model), inertia_moments)  # refused there, by name
    path = Path(model.path if isinstance(model, MJCFBody) else model)
    try:
        stat = path.stat()
    except OSError:  # load_mujoco says what is wrong with it
        return _with_moments(*_prepare(model), inertia_moments)
    moments = None if inertia_moments is None else tuple(float(x) for x in np.ravel(inertia_moments))
    key = (str(path), stat.st_mtime_ns, stat.st_size, moments)
    if key not in _MODELS:
        if len(_MODELS) > 16:
            _MODELS.clear()
        _MODELS[key] = _with_moments(*_prepare(model), inertia_moments)
    return _MODELS[key]


def _with_moments(m, body, inertia_moments):
    if inertia_moments is not None:
        from ..body import validate_inertia

        moments = np.asarray(inertia_moments, dtype=float)
        validate_inertia(moments, name="inertia_moments")
        m.body_inertia[body.body_id] = moments
        mujoco.mj_setConst(m, mujoco.MjData(m))  # the constants derived from it (dof_M0, invweights) follow
    return m, body


def simulate(model, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None,
             torque_mode: str = "callback", inertia_moments=None, wheel_speeds=None) -> Trajectory:
    """Run MuJoCo on one free body.

    Parameters
    ----------
    model : path or MJCFBody
        The MJCF (checked by :func:`xcheck.models.load_mujoco`).
    integrator : "euler" | "implicit" | "implicitfast" | "rk4"
        MuJoCo's own (method names in the cross-check: ``mujoco-<integrator>``).
    q0 : (4,) [w, x, y, z] body -> world; omega0 : (3,) body rate [rad/s].
    dt, duration : float
        [s]; the run ends exactly at ``duration`` (a shortened last step, as our integrators).
    torque : None, TorqueModel or callable ``(t, q, omega) -> (3,)``
        Body-frame torque [N m], evaluated at every stage (``torque_mode="callback"``) or once per step
        and held (``"held"``).
    inertia_moments : None or (3,)
        Principal moments [kg m^2] written into the compiled model's ``body_inertia`` (the principal axes,
        ``body_iquat``, kept): a sweep's inertia axis without rewriting the MJCF. None: the MJCF's own.
    wheel_speeds : None or (k,)
        A gyrostat's wheels' initial speeds relative to the body [rad/s] (None: the model's,
        :attr:`xcheck.models.Wheel.speed`); their motors' pulses are set in ``ctrl`` at every stage, like a torque.

    Returns
    -------
    Trajectory, with the MuJoCo version in ``extras["mujoco_version"]`` (and a gyrostat's wheels' speeds relative
    to the body in ``extras["wheel_speeds"]``, (n, k)).
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: unknown {integrator!r}; expected one of {', '.join(INTEGRATORS)}")
    if torque_mode not in ("callback", "held"):
        raise ValueError(f"torque_mode: expected 'callback' or 'held', got {torque_mode!r}")
    m, body, d, n, last_h = initial_data(model, INTEGRATORS[integrator], q0, omega0, dt, duration, torque,
                                         inertia_moments, wheel_speeds)
    t = time_grid(n, float(dt), float(duration))
    with mujoco_warnings() as messages:
        if torque is None and not any(w.pulse for w in body.wheels):
            qpos, qvel = _rollout_free(m, d, n, last_h)
        else:
            qpos, qvel = _stepped(m, d, n, last_h, body, torque, torque_mode)
    method = f"mujoco-{integrator}"
    k = _first_bad_row(qpos, qvel)
    traj = run_trajectory(body, t, qpos, qvel, n + 1 if k is None else k, method, integrator, dt,
                          {"mujoco_version": mujoco.__version__})
    if messages or k is not None:
        traj.status = "failed"
        where = f"at t = {t[k]:.6g} s" if k is not None else "during the run"
        said = " ".join(list(dict.fromkeys(m.strip() for m in messages))[:3]) or "the state became non-finite or huge"
        traj.message = f"{method}: the simulation blew up {where}; MuJoCo: {said}"
    return traj


def initial_data(model, integrator, q0, omega0, dt, duration, torque, inertia_moments, wheel_speeds):
    """A run's compiled model (its integrator, an ``mjtIntegrator``, and step set; MuJoCo's reset on a blow-up off)
    and its ``MjData`` at the initial state, a gyrostat's wheels at their speeds, with the step plan ``(n,
    last_h)``: ``(m, body, d, n, last_h)``, the arguments checked as every run of an MJCF checks them (MuJoCo's
    and MJX's)."""
    m, body = _model_for_runs(model, inertia_moments)
    q0, omega0 = check_initial_state(q0, omega0)
    n, last_h = step_plan(dt, duration)
    if isinstance(torque, TorqueModel):
        torque.check_span(duration)
    elif torque is not None and not callable(torque):
        raise ValueError(f"torque: expected None, a TorqueModel or a callable (t, q, omega) -> (3,), got "
                         f"{type(torque).__name__}")
    m.opt.integrator = integrator
    m.opt.timestep = float(dt)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET  # a blow-up must show, not restart from rest
    d = mujoco.MjData(m)
    d.qpos[body.quat_slice] = body.to_joint(q0)  # a ball joint's qpos is relative to the body's reference orientation
    d.qvel[body.rate_slice] = omega0
    for wheel, speed in zip(body.wheels, body.wheel_speeds0(wheel_speeds)):
        d.qvel[wheel.dof] = speed
    return m, body, d, n, last_h


def run_trajectory(body, t, qpos, qvel, stop, method, integrator, dt, extras) -> Trajectory:
    """The Trajectory of a run's first ``stop`` rows of ``qpos``/``qvel`` (the body's world attitude, its rate, a
    gyrostat's wheel speeds in ``extras``), with its forward dynamics' evaluations: four a step in RK4, one in the
    Euler variants."""
    extras = {**extras, "evaluations": (4 if integrator == "rk4" else 1) * (stop - 1)}
    if body.wheels:
        extras["wheel_speeds"] = qvel[:stop, [w.dof for w in body.wheels]].copy()
    q = continuous_quaternions(body.from_joint(qpos[:stop, body.quat_slice]))
    return Trajectory(t=t[:stop], q=q, omega=qvel[:stop, body.rate_slice].copy(), method=method, dt=float(dt),
                      extras=extras)


def _rollout_free(m, d, n, last_h):
    """``rollout`` of ``d`` itself for the equal steps, one ``mj_step`` for a shortened last step (torque free, or
    with the torque in the control callback)."""
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(m, spec)
    state0 = np.empty(size)
    mujoco.mj_getState(m, d, state0, spec)
    equal = n if abs(last_h - m.opt.timestep) <= 1e-12 * m.opt.timestep else n - 1
    states = np.empty((equal + 1, size))
    states[0] = state0
    if equal:
        out, _ = rollout.rollout(m, d, state0[None, :], nstep=equal)
        states[1:] = out[0]
    if equal < n:  # the shortened last step
        mujoco.mj_setState(m, d, states[equal], spec)
        m.opt.timestep = last_h
        mujoco.mj_step(m, d)
        last = np.empty(size)
        mujoco.mj_getState(m, d, last, spec)
        states = np.vstack([states, last])
    return states[:, 1:1 + m.nq], states[:, 1 + m.nq:1 + m.nq + m.nv]


def _stepped(m, d, n, last_h, body, torque, torque_mode):
    """The torque applied in the control callback, at every stage, through ``rollout`` (its C loop of
    ``mj_step`` on this very ``d``, whose buffers the callback reads and writes: 3.4x the steps per second of a
    Python loop, the same numbers); or held, written before each ``mj_step`` of a Python loop."""
    # views into MjData's fixed buffers, made once
    w_view = d.qvel[body.rate_slice]
    tau_view = d.qfrc_applied[body.rate_slice]
    if body.joint == "free":  # the joint's quaternion is the world attitude a torque model reads
        q_view = d.qpos[body.quat_slice]

        def attitude():
            return q_view
    else:  # a ball joint's is relative to the body's reference orientation: the world attitude made at every call
        joint_q, q_view = d.qpos[body.quat_slice], np.empty(4)

        def attitude():
            q_view[:] = body.from_joint(joint_q)
            return q_view
    if torque is None:
        def body_torque(t, out):
            pass
    elif isinstance(torque, TorqueModel):
        kind, P, T = torque.kernel_data()

        def body_torque(t, out):
            torque_eval(kind, P, T, t, attitude(), w_view, out)
    else:
        def body_torque(t, out):
            q = attitude()
            out[:] = np.asarray(torque(t, q / np.linalg.norm(q), w_view.copy()), dtype=float)
    body_torque = _with_motor_commands(body, d, body_torque)

    if torque_mode == "callback":
        def callback(model, data):
            if data is not d:  # a rollout stepping a copy of d (an older MuJoCo): that copy's state, not d's
                raise RuntimeError("MuJoCo's rollout stepped another MjData than the one given")
            body_torque(data.time, tau_view)

        with control_callback(callback):
            return _rollout_free(m, d, n, last_h)
    qpos_out = np.empty((n + 1, m.nq))
    qvel_out = np.empty((n + 1, m.nv))
    qpos_out[0], qvel_out[0] = d.qpos, d.qvel
    tau = np.empty(3)
    force = d.xfrc_applied[body.body_id]

    def before_step():
        body_torque(d.time, tau)
        force[3:6] = rot.quat_rotate(q_view, tau)  # xfrc_applied takes world-frame torque

    _loop(m, d, n, last_h, qpos_out, qvel_out, before_step)
    return qpos_out, qvel_out


def _with_motor_commands(body, d, body_torque):
    """``body_torque`` that also sets a gyrostat's motors' ``ctrl`` at each stage's time (their pulses,
    :func:`xcheck.fields.kernel.pulse`, divided by each motor's gain); ``body_torque`` itself without one (the
    callback of every other run keeps its one call)."""
    from ..fields.kernel import pulse

    driven = [(w.actuator, w.gain, *w.pulse) for w in body.wheels if w.pulse is not None]
    if not driven:
        return body_torque
    ctrl = d.ctrl

    def with_commands(t, out):
        for actuator, gain, peak, t0, t1 in driven:
            ctrl[actuator] = pulse(peak, t0, t1, t)[1] / gain
        body_torque(t, out)
    return with_commands


def _loop(m, d, n, last_h, qpos_out, qvel_out, before_step=None):
    dt = m.opt.timestep
    for k in range(n):
        if k == n - 1:
            m.opt.timestep = last_h
        if before_step is not None:
            before_step()
        mujoco.mj_step(m, d)
        qpos_out[k + 1] = d.qpos
        qvel_out[k + 1] = d.qvel
    m.opt.timestep = dt


def free_flight(model_path, *, integrator: str, omega0, v0, gravity, dt: float, nsteps: int):
    """MuJoCo flying a free body whole, translation and all, as the boxes benchmark does (:mod:`xcheck.league`): the
    MJCF as written but for ``opt.gravity`` [m/s^2], the body at the origin at rest in the identity attitude with
    ``v0`` [m/s] (world) and ``omega0`` [rad/s] (body; the identity start makes it world too), ``nsteps`` steps of
    ``dt`` [s] through ``rollout``. Returns ``(t, c, q, v, omega)``, (nsteps + 1) rows: the centre of mass [m] (the
    body's origin, where its MJCF puts the centre), [w, x, y, z], [m/s] world, [rad/s] body."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: unknown {integrator!r}; expected one of {', '.join(INTEGRATORS)}")
    m = mujoco.MjModel.from_xml_path(str(model_path))
    if m.njnt != 1 or m.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError(f"{model_path}: free_flight takes one body on a free joint")
    m.opt.gravity[:] = gravity
    m.opt.integrator = INTEGRATORS[integrator]
    m.opt.timestep = float(dt)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    d = mujoco.MjData(m)
    d.qpos[:] = [0, 0, 0, 1, 0, 0, 0]
    d.qvel[:] = [*v0, *omega0]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)
    out, _ = rollout.rollout(m, d, state0[None, :], nstep=int(nsteps))
    states = np.vstack([state0, out[0]])
    qpos, qvel = states[:, 1:8], states[:, 8:14]
    return states[:, 0], qpos[:, :3], qpos[:, 3:7], qvel[:, :3], qvel[:, 3:6]


def bench_extras(contexts, dt, nsteps, repeat):
    """``xcheck bench`` rows of MuJoCo's own: bare ``mj_step`` calls (RK4, torque free) in a Python loop, no
    state read back: MuJoCo's per-step rate without anything of ours around it."""
    import time

    ctx = contexts["gyroscope-nonsingular"]
    m, body = _prepare(ctx.model_path)
    m.opt.timestep = dt
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    best = np.inf
    for _ in range(repeat):
        d = mujoco.MjData(m)
        d.qpos[body.quat_slice] = body.to_joint(ctx.q0)
        d.qvel[body.rate_slice] = ctx.omega0
        step = mujoco.mj_step
        t0 = time.perf_counter()
        for _ in range(nsteps):
            step(m, d)
        best = min(best, time.perf_counter() - t0)
    return [("mujoco-rk4 (mj_step loop)", "gyroscope-nonsingular", best, nsteps)]


def magnetometer_readings(model, q, B_world) -> np.ndarray:
    """MuJoCo's ``<magnetometer>`` on a body's attitudes: the MJCF with a site at the body's origin (its frame)
    carrying a magnetometer, ``opt.magnetic = B_world`` [T] (MuJoCo's field is uniform), and each attitude
    ``q`` (T, 4) set and ``mj_forward`` run. Returns the readings (T, 3) [T] in body components."""
    _, body = _prepare(model)
    spec = mujoco.MjSpec.from_file(str(body.path))
    site = spec.bodies[body.body_id].add_site(name="xcheck_determination_magnetometer")
    spec.add_sensor(name="xcheck_determination_magnetometer", type=mujoco.mjtSensor.mjSENS_MAGNETOMETER,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
    spec.option.magnetic = np.asarray(B_world, dtype=float)
    m = spec.compile()
    sensor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "xcheck_determination_magnetometer")
    adr = m.sensor_adr[sensor]
    d = mujoco.MjData(m)
    out = np.empty((len(q), 3))
    for k, qk in enumerate(np.asarray(q, dtype=float)):
        d.qpos[body.quat_slice] = body.to_joint(qk)
        mujoco.mj_forward(m, d)
        out[k] = d.sensordata[adr:adr + 3]
    return out
