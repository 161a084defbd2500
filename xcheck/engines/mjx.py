"""MJX, MuJoCo's JAX port (PyPI ``mujoco-mjx``, the extra ``mjx``), as a runner (issue 29): the same body, initial
state and torque as MuJoCo's runner, MJX's ``step`` on JAX's CPU backend, in float32 (JAX's default) or float64
(``x64``: ``jax_enable_x64`` for the run).

* MJX has no control callback: an applied torque is evaluated once per step, at the step's start, and held over it
  in ``xfrc_applied`` (world components), as are a gyrostat's motor commands in ``ctrl``; a host callback
  (``jax.pure_callback``, 0.1-0.4 ms a step: such runs are 10-20x slower than torque-free ones) evaluates our
  torque model, JAX the motors' pulses. Held inputs cost a method its order above 1 (the study declares it:
  ``xcheck.runners`` ``_held_input_order``). A torque the model exerts itself (a top's gravity, free
  wheels) is MJX's own, at every stage.
* The steps run in chunks of :data:`CHUNK` through ``jax.lax.scan``, each step's length an input (a shortened last
  step and the padding of the last chunk, steps of length 0 whose states are dropped, take no retrace): one compilation per model, integrator,
  precision and input kind, kept per process and in JAX's persistent cache under xcheck's user cache
  (``jax/``: 3 s a compilation the first time, 0.8 s from the cache).
* A blow-up is a failed run, as in MuJoCo's runner: the trajectory ends at the last finite step.
"""

from __future__ import annotations

import numpy as np

from .. import rotations as rot
from ..fields import TorqueModel, torque_eval
from ..trajectory import Trajectory, time_grid

__all__ = ["simulate", "INTEGRATORS", "CHUNK", "bench_extras"]

#: MJX's integrators (its ``implicit`` is not implemented in MJX)
INTEGRATORS = ("euler", "rk4", "implicitfast")
CHUNK = 256

_JAX: dict = {}
_FUNCS: dict = {}
#: the running simulation's host inputs: the compiled chunk calls whichever is here, so that one compilation serves
#: every run of a model, integrator and precision (a closure per run would recompile each: 3 s a run)
_INPUTS: dict = {}


def _dispatch(t, qpos, qvel):
    return _INPUTS["now"](t, qpos, qvel)


def jax_modules():
    """``(jax, mjx)``, imported once: JAX on its CPU backend, its compilations cached under xcheck's user cache."""
    if not _JAX:
        import jax

        from .._jit import user_cache_home

        jax.config.update("jax_platforms", "cpu")
        jax.config.update("jax_compilation_cache_dir", str(user_cache_home() / "jax"))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
        jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
        import contextlib
        import io

        with contextlib.redirect_stdout(io.StringIO()):  # MJX prints "Failed to import warp" where Warp is absent
            from mujoco import mjx

        _JAX.update(jax=jax, mjx=mjx)
    return _JAX["jax"], _JAX["mjx"]


def _set_precision(jax, x64: bool) -> None:
    """JAX in float64 (``x64``) or float32, for the whole process (the flag ``jax_enable_x64``: its context manager
    is thread-local, and a host callback runs on another thread, where it would turn float64 results into float32).
    JAX's caches of MJX's inner jitted functions do not tell the two apart (float32 code was called with float64
    operands: MLIR's verifier refused it), so they, and ours, are cleared whenever a process changes precision: a
    compilation more (0.8 s from the persistent cache)."""
    if _JAX.get("x64") is not None and _JAX["x64"] != x64:
        jax.clear_caches()
        _FUNCS.clear()
    _JAX["x64"] = x64
    jax.config.update("jax_enable_x64", x64)


def _chunk_function(key, torque: bool, motors: tuple):
    """The jitted chunk of steps for ``key`` (model, integrator, precision, inputs): ``(mx, dx, h (CHUNK,)) -> (dx,
    (qpos (CHUNK, nq), qvel (CHUNK, nv)))``. Before each step, held over it: with ``torque``, the running simulation's
    applied torque from the host (:data:`_INPUTS`: ``(t, qpos, qvel) -> (nbody, 6)`` of ``xfrc_applied``, a host
    callback, 0.1-0.4 ms a step); the ``motors``' commands ``(actuator, gain, peak, t0, t1)``, their pulses
    :func:`xcheck.fields.kernel.pulse` in JAX."""
    if key in _FUNCS:
        return _FUNCS[key]
    jax, mjx = jax_modules()
    jnp = jax.numpy

    def commands(dx):
        ctrl = dx.ctrl
        for actuator, gain, peak, t0, t1 in motors:  # u sin^2(pi s) on [t0, t1], zero outside
            s = jnp.clip((dx.time - t0) / (t1 - t0), 0.0, 1.0)
            ctrl = ctrl.at[actuator].set(peak * jnp.sin(jnp.pi * s) ** 2 / gain)
        return dx.replace(ctrl=ctrl)

    def chunk(mx, dx, hs):
        def one(dx, h):
            if torque:
                xfrc = jax.pure_callback(_dispatch, jax.ShapeDtypeStruct(dx.xfrc_applied.shape, dx.qpos.dtype),
                                         dx.time, dx.qpos, dx.qvel)
                dx = dx.replace(xfrc_applied=xfrc)
            if motors:
                dx = commands(dx)
            dx = mjx.step(mx.replace(opt=mx.opt.replace(timestep=h)), dx)  # the last chunk's padding: h = 0, dropped
            return dx, (dx.qpos, dx.qvel)

        return jax.lax.scan(one, dx, hs)

    _FUNCS[key] = jax.jit(chunk)
    if len(_FUNCS) > 64:
        _FUNCS.pop(next(iter(_FUNCS)))
    return _FUNCS[key]


def simulate(model, *, integrator: str, q0, omega0, dt: float, duration: float, torque=None, x64: bool = False,
             inertia_moments=None, wheel_speeds=None) -> Trajectory:
    """Run MJX on one body (the arguments as :func:`xcheck.engines.mujoco.simulate`'s); ``x64``: float64 instead of
    JAX's float32. Returns a Trajectory (method ``mjx-<integrator>`` or ``mjx-<integrator>-x64``) with the MJX and
    JAX versions in ``extras``."""
    import mujoco

    from ..base.packages import package_version
    from .mujoco import _first_bad_row, initial_data, run_trajectory

    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: unknown {integrator!r}; MJX has {', '.join(INTEGRATORS)}")
    jax, mjx = jax_modules()
    m, body, d, n, last_h = initial_data(model, getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}"), q0,
                                         omega0, dt, duration, torque, inertia_moments, wheel_speeds)
    motors = tuple((w.actuator, float(w.gain), *map(float, w.pulse)) for w in body.wheels if w.pulse is not None)
    dtype = np.float64 if x64 else np.float32
    inputs = _host_torque(m, body, torque, dtype) if torque is not None else None
    hs = np.full(n, float(dt))
    hs[-1] = last_h
    pad = (-n) % CHUNK
    hs = np.concatenate([hs, np.zeros(pad)]).astype(dtype)
    qpos, qvel = [np.asarray(d.qpos, dtype=float)[None]], [np.asarray(d.qvel, dtype=float)[None]]
    _set_precision(jax, x64)
    mx = mjx.put_model(m)
    dx = mjx.put_data(m, d)
    f = _chunk_function((id(m), integrator, x64, torque is not None, motors), torque is not None, motors)
    _INPUTS["now"] = inputs
    for k in range(0, n + pad, CHUNK):
        dx, (p, v) = f(mx, dx, hs[k:k + CHUNK])
        qpos.append(np.asarray(p, dtype=float))
        qvel.append(np.asarray(v, dtype=float))
        if not (np.all(np.isfinite(qpos[-1])) and np.all(np.isfinite(qvel[-1]))):
            break
    _INPUTS.pop("now", None)
    qpos = np.concatenate(qpos)[: n + 1]
    qvel = np.concatenate(qvel)[: n + 1]
    t = time_grid(n, float(dt), float(duration))
    k = _first_bad_row(qpos, qvel)
    stop = len(qpos) if k is None else k
    method = f"mjx-{integrator}" + ("-x64" if x64 else "")
    extras = {"mujoco_version": mujoco.__version__, "mjx_version": package_version("mujoco-mjx"),
              "jax_version": jax.__version__, "precision": "float64" if x64 else "float32"}
    if torque is not None or motors:
        extras["torque_input"] = "held over each step (xfrc_applied, ctrl): MJX has no control callback"
    traj = run_trajectory(body, t, qpos, qvel, stop, method, integrator, dt, extras)
    if stop < n + 1:
        traj.status = "failed"
        traj.message = f"{method}: the simulation blew up at t = {t[stop]:.6g} s (a non-finite or huge state)"
    return traj


def _host_torque(m, body, torque, dtype):
    """``(t, qpos, qvel) -> xfrc_applied (nbody, 6)`` in the run's precision: the body's torque at the step's start, in
    world components."""
    nbody = m.nbody
    qs, ws = body.quat_slice, body.rate_slice
    out, xfrc = np.empty(3), np.zeros((nbody, 6))
    if isinstance(torque, TorqueModel):
        kind, P, T = torque.kernel_data()

        def body_torque(t, q, w):
            torque_eval(kind, P, T, t, q, w, out)
            return out
    else:
        def body_torque(t, q, w):
            return np.asarray(torque(t, q, w.copy()), dtype=float)

    def inputs(t, qpos, qvel):
        qpos, qvel = np.asarray(qpos, dtype=float), np.asarray(qvel, dtype=float)
        q = body.from_joint(qpos[qs])
        q = q / np.linalg.norm(q)
        xfrc[body.body_id, 3:6] = rot.quat_rotate(q, body_torque(float(t), q, qvel[ws]))
        return xfrc.astype(dtype)

    return inputs


def batch_rollout(model, *, integrator: str, q0, omega0, dt: float, nsteps: int, x64: bool = False):
    """MJX's batched steps (``jax.vmap`` of one step over N bodies, ``nsteps`` steps of ``dt``, torque free), the final
    states ``(qpos (N, nq), qvel (N, nv))``: what xcheck bench times."""
    import mujoco

    from .mujoco import _model_for_runs

    jax, mjx = jax_modules()
    m, body = _model_for_runs(model, None)
    m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    m.opt.timestep = float(dt)
    d = mujoco.MjData(m)
    q0, omega0 = np.atleast_2d(q0), np.atleast_2d(omega0)
    dtype = np.float64 if x64 else np.float32
    _set_precision(jax, x64)
    mx = mjx.put_model(m)
    dx = mjx.put_data(m, d)
    qpos = np.repeat(np.asarray(d.qpos)[None], len(q0), axis=0)
    qvel = np.repeat(np.asarray(d.qvel)[None], len(q0), axis=0)
    qpos[:, body.quat_slice] = body.to_joint(q0)
    qvel[:, body.rate_slice] = omega0
    key = ("batch", id(m), integrator, x64, len(q0), nsteps)
    if key not in _FUNCS:
        def run(mx, dx):
            def one(dx, _):
                return jax.vmap(mjx.step, in_axes=(None, 0))(mx, dx), None
            return jax.lax.scan(one, dx, None, length=nsteps)[0]
        _FUNCS[key] = jax.jit(run)
    batch = jax.vmap(lambda p, v: dx.replace(qpos=p, qvel=v))(qpos.astype(dtype), qvel.astype(dtype))
    out = _FUNCS[key](mx, batch)
    return np.asarray(out.qpos), np.asarray(out.qvel)


def bench_extras(contexts, dt, nsteps, repeat):
    """``xcheck bench`` rows of MJX's own, ``(method, scenario, seconds, steps, batch)``: batched RK4 steps of N = 1000
    gyroscopes (float32, then float64), the first call (its compilation) not timed."""
    import time

    ctx = contexts["gyroscope-nonsingular"]
    rows = []
    n_bodies, steps = 1000, max(10, nsteps // 100)
    q0 = np.repeat(np.asarray(ctx.q0)[None], n_bodies, axis=0)
    w0 = np.repeat(np.asarray(ctx.omega0)[None], n_bodies, axis=0)
    for x64 in (False, True):
        batch_rollout(ctx.model_path, integrator="rk4", q0=q0, omega0=w0, dt=dt, nsteps=steps, x64=x64)
        best = np.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            batch_rollout(ctx.model_path, integrator="rk4", q0=q0, omega0=w0, dt=dt, nsteps=steps, x64=x64)
            best = min(best, time.perf_counter() - t0)
        rows.append((f"mjx-rk4{'-x64' if x64 else ''} (vmap)", "gyroscope-nonsingular", best, steps, n_bodies))
    return rows
