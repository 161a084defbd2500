"""DOP853 compiled: the rigid body's equations under any torque model, integrated by Dormand and Prince's
eighth-order pair with its seventh-order dense output, in one compiled call.

The same algorithm as scipy's ``DOP853`` (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.5 and §II.10; scipy's
``_ivp/rk.py``): its coefficients (read from scipy, the published tableau), its error norm (the fifth- and
third-order estimates combined), its step-size control (safety 0.9, factors 0.2 to 10, no growth after a rejected
step), its initial step and its dense output. What differs is only where the time goes: scipy's steps cost
~150 us each in Python, this one's ~2 us, so an independent high-accuracy integration is cheap enough to check
a closed form in every study (:mod:`xcheck.study.context`) and thousands of bodies in a test.

State ``y = [q (4), w (3)]``: ``q' = 1/2 q ⊗ (0, w)`` (seed 004 eq. 162), ``w' = I^-1 (tau - w x I w)`` (eq. 143),
``tau`` the torque model's (:func:`xcheck.fields.kernel.torque_eval`, which normalises ``q``) — the same right-hand
side as :func:`xcheck.reference.rigid_body_rhs`.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import scipy

from .._jit import njit, stop_requested
from ..base.interrupts import compiled_run_flag, raise_stopped
from ..fields import TorqueModel
from ..fields.kernel import torque_eval

__all__ = ["dop853_dense", "dop853_at", "DenseSolution", "DOP853Failure", "COMPILED_DOP853_STATUS", "warm"]

def _scipy_coefficients():
    """scipy's module of DOP853's coefficients (Hairer's published tableau), loaded from its file alone: importing it
    the usual way imports ``scipy.integrate`` first (0.13 s a process, where the study needs none of it)."""
    path = Path(scipy.__file__).parent / "integrate" / "_ivp" / "dop853_coefficients.py"
    if not path.is_file():  # a scipy laid out otherwise
        from scipy.integrate._ivp import dop853_coefficients

        return dop853_coefficients
    spec = importlib.util.spec_from_file_location("xcheck_dop853_coefficients", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_coefficients = _scipy_coefficients()
_S = _coefficients.N_STAGES  # 12
_A = np.ascontiguousarray(_coefficients.A, dtype=float)  # (16, 16): the 12 stages, the step's end, 3 more for the dense output
_C = np.ascontiguousarray(_coefficients.C, dtype=float)
_B = np.ascontiguousarray(_coefficients.B, dtype=float)
_E3 = np.ascontiguousarray(_coefficients.E3, dtype=float)
_E5 = np.ascontiguousarray(_coefficients.E5, dtype=float)
_D = np.ascontiguousarray(_coefficients.D, dtype=float)  # (4, 16)

#: A step's error estimate is not trusted below the rounding of its own stages: the rate's derivative
#: ``Iinv (tau - w x I w)`` carries ``eps |w| |I w|`` from the cross product's cancellation, times the row sums of
#: ``|Iinv|`` (a thin rod's moment of 1e-8 kg m^2 makes that 1e-5 rad/s^2: at rtol 1e-12 DOP853 shrank its steps to
#: 1e-7 s, chasing it, and ran out of its budget of a million steps in 5 s; issue 58). Each rate's tolerance is
#: widened by this many times ``h`` times that rounding (twice the sum of the error weights' magnitudes: the noise
#: then moves the error norm by at most a half), so the truncation error alone controls the step. Only where
#: :data:`NOISY_REJECTIONS` steps were rejected with that rounding above their tolerance (status 6) is the run made
#: again so (``aware``): a bundled body's run at rtol 2.5e-14 has a few such rejections, the thin rod's every one,
#: and the bundled references are what they were.
NOISE_FACTOR = 2.0 * float(np.abs(_E5).sum())
NOISY_REJECTIONS = 1000
EPS = float(np.finfo(float).eps)

class DOP853Failure(RuntimeError):
    """The compiled DOP853 stopped before the end (:data:`COMPILED_DOP853_STATUS` says why: its budget, a
    non-finite state, a step too small)."""


#: What the kernel's status means.
COMPILED_DOP853_STATUS = {0: "ok", 1: "more steps than its budget", 2: "the state became non-finite",
                          3: "the step became too small", 4: "its dense output's rows ran out", 5: "interrupted",
                          6: "its steps were rejected for the rounding of its own stages"}


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(t, y, I, Iinv, kind, P, T, tau, out):
    q0, q1, q2, q3, wx, wy, wz = y[0], y[1], y[2], y[3], y[4], y[5], y[6]
    torque_eval(kind, P, T, t, y[0:4], y[4:7], tau)
    out[0] = 0.5 * (-q1 * wx - q2 * wy - q3 * wz)
    out[1] = 0.5 * (q0 * wx + q2 * wz - q3 * wy)
    out[2] = 0.5 * (q0 * wy + q3 * wx - q1 * wz)
    out[3] = 0.5 * (q0 * wz + q1 * wy - q2 * wx)
    hx = I[0, 0] * wx + I[0, 1] * wy + I[0, 2] * wz
    hy = I[1, 0] * wx + I[1, 1] * wy + I[1, 2] * wz
    hz = I[2, 0] * wx + I[2, 1] * wy + I[2, 2] * wz
    rx = tau[0] - (wy * hz - wz * hy)
    ry = tau[1] - (wz * hx - wx * hz)
    rz = tau[2] - (wx * hy - wy * hx)
    out[4] = Iinv[0, 0] * rx + Iinv[0, 1] * ry + Iinv[0, 2] * rz
    out[5] = Iinv[1, 0] * rx + Iinv[1, 1] * ry + Iinv[1, 2] * rz
    out[6] = Iinv[2, 0] * rx + Iinv[2, 1] * ry + Iinv[2, 2] * rz


@njit(cache=True, error_model="numpy", inline="always", _nrt=False)
def _stages(first, last, t, h, y, A, C, K, ytmp, I, Iinv, kind, P, T, tau):
    """The stages ``first`` to ``last - 1`` of a step of ``h`` from ``(t, y)`` into the rows of ``K`` (row ``s`` from
    the rows before it, by the tableau's row ``A[s]``)."""
    for s in range(first, last):
        for i in range(7):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        _rhs(t + C[s] * h, ytmp, I, Iinv, kind, P, T, tau, K[s])


@njit(cache=True, error_model="numpy", inline="always", _nrt=False)
def _rms(x, scale):
    s = 0.0
    for i in range(x.shape[0]):
        v = x[i] / scale[i]
        s += v * v
    return np.sqrt(s / x.shape[0])


@njit(cache=True, error_model="numpy", inline="always", _nrt=False)
def _dense_value(F, k, y_old, x, out, row):
    """The dense output of step ``k`` (its coefficients ``F[k]``, its start ``y_old``) at the fraction ``x`` of it."""
    for c in range(7):
        v = 0.0
        for r in range(7):  # scipy's order: from the last coefficient, x and 1 - x alternately
            v += F[k, 6 - r, c]
            v *= x if r % 2 == 0 else 1.0 - x
        out[row, c] = v + y_old[c]


@njit(cache=True, error_model="numpy", _nrt=False, nogil=True)
def _solve(y0, ends, rtol, atol, max_steps, I, Iinv, kind, P, T, A, C, B, E3, E5, D, aware, store, t_query, out, ts, yo,
           F, work, stop):
    """From 0 through each time of ``ends`` in turn (restarting there: a torque's breakpoints, then the duration),
    writing the dense output at each time of ``t_query`` (ascending) into ``out`` as the step that covers it is taken.
    With ``store``, every step's dense output is kept in ``ts`` (steps + 1), ``yo`` (steps, 7) and ``F`` (steps, 7, 7)
    (else only the current one, in their first row: no memory grows with the run). Nothing is allocated (no numba
    runtime to load: its first use costs a process ~0.1 s): ``work`` (16 + 8, 7) is the scratch. Returns ``(status,
    steps)``; status 4 where ``store`` ran out of rows, 5 where ``stop`` was set (polled every step:
    :func:`xcheck.base.interrupts.stop_flag`), 6 where :data:`NOISY_REJECTIONS` steps were rejected with the rates'
    rounding above their tolerance and not ``aware`` (see :data:`NOISE_FACTOR`) (:data:`COMPILED_DOP853_STATUS`)."""
    n = 7
    S = 12
    K = work[0:16]
    y, y_new, ytmp, f, scale, err5, err3, tau = (work[16], work[17], work[18], work[19], work[20], work[21], work[22],
                                                 work[23, 0:3])
    noise = work[23, 3:6]
    for i in range(n):
        y[i] = y0[i]
    capacity = yo.shape[0]
    ts[0] = 0.0
    steps = 0
    iq = 0
    while iq < t_query.shape[0] and t_query[iq] <= 0.0:  # the start itself
        for c in range(n):
            out[iq, c] = y0[c]
        iq += 1
    t = 0.0
    exponent = -1.0 / 8.0
    noisy_rejections = 0
    for e in range(ends.shape[0]):
        t_bound = ends[e]
        _rhs(t, y, I, Iinv, kind, P, T, tau, f)
        # scipy's select_initial_step (order 7 error estimator)
        for i in range(n):
            scale[i] = atol + abs(y[i]) * rtol
        d0 = _rms(y, scale)
        d1 = _rms(f, scale)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, t_bound - t)
        for i in range(n):
            ytmp[i] = y[i] + h0 * f[i]
        _rhs(t + h0, ytmp, I, Iinv, kind, P, T, tau, err5)
        for i in range(n):
            err5[i] = err5[i] - f[i]
        d2 = _rms(err5, scale) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
        h_abs = min(100 * h0, h1, t_bound - t)
        while t < t_bound:
            if steps >= max_steps:
                return 1, steps
            if stop_requested(stop):
                return 5, steps
            # the rounding of the rates' derivatives at this step's start (see NOISE_FACTOR)
            wn, Iwn = 0.0, 0.0
            for i in range(3):
                wn += y[4 + i] * y[4 + i]
                Iwi = I[i, 0] * y[4] + I[i, 1] * y[5] + I[i, 2] * y[6]
                Iwn += Iwi * Iwi
            rounding = NOISE_FACTOR * EPS * np.sqrt(wn * Iwn)
            for i in range(3):
                noise[i] = rounding * (abs(Iinv[i, 0]) + abs(Iinv[i, 1]) + abs(Iinv[i, 2]))
            if store and steps >= capacity:
                return 4, steps
            min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
            rejected = False
            while True:
                if h_abs < min_step:
                    return 3, steps
                t_new = t + h_abs
                if t_new > t_bound:
                    t_new = t_bound
                h = t_new - t
                h_abs = abs(h)
                for i in range(n):
                    K[0, i] = f[i]
                _stages(1, S, t, h, y, A, C, K, ytmp, I, Iinv, kind, P, T, tau)
                for i in range(n):
                    acc = 0.0
                    for j in range(S):
                        acc += B[j] * K[j, i]
                    y_new[i] = y[i] + h * acc
                _rhs(t + h, y_new, I, Iinv, kind, P, T, tau, K[S])
                noisy = False
                for i in range(n):
                    scale[i] = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                    if i >= 4:
                        if aware:
                            scale[i] += h_abs * noise[i - 4]
                        elif h_abs * noise[i - 4] > scale[i]:
                            noisy = True
                    a5 = 0.0
                    a3 = 0.0
                    for j in range(S + 1):
                        a5 += E5[j] * K[j, i]
                        a3 += E3[j] * K[j, i]
                    err5[i] = a5 / scale[i]
                    err3[i] = a3 / scale[i]
                n5 = 0.0
                n3 = 0.0
                for i in range(n):
                    n5 += err5[i] * err5[i]
                    n3 += err3[i] * err3[i]
                if n5 == 0.0 and n3 == 0.0:
                    error_norm = 0.0
                else:
                    error_norm = abs(h) * n5 / np.sqrt((n5 + 0.01 * n3) * n)
                if not np.isfinite(error_norm):
                    return 2, steps
                if error_norm < 1.0:
                    if error_norm == 0.0:
                        factor = 10.0
                    else:
                        factor = min(10.0, 0.9 * error_norm ** exponent)
                    if rejected:
                        factor = min(1.0, factor)
                    h_abs *= factor
                    break
                if noisy:
                    noisy_rejections += 1
                    if noisy_rejections >= NOISY_REJECTIONS:
                        return 6, steps
                h_abs *= max(0.2, 0.9 * error_norm ** exponent)
                rejected = True
            k = steps if store else 0
            needed = store or (iq < t_query.shape[0] and t_query[iq] <= t_new)
            # the dense output's three extra stages and its coefficients (scipy's Dop853DenseOutput)
            if needed:
                _stages(S + 1, 16, t, h, y, A, C, K, ytmp, I, Iinv, kind, P, T, tau)
            if needed:
                for i in range(n):
                    dy = y_new[i] - y[i]
                    F[k, 0, i] = dy
                    F[k, 1, i] = h * K[0, i] - dy
                    F[k, 2, i] = 2.0 * dy - h * (K[S, i] + K[0, i])
                    for r in range(4):
                        acc = 0.0
                        for j in range(16):
                            acc += D[r, j] * K[j, i]
                        F[k, 3 + r, i] = h * acc
                    yo[k, i] = y[i]
                while iq < t_query.shape[0] and t_query[iq] <= t_new:
                    _dense_value(F, k, yo[k], (t_query[iq] - t) / h, out, iq)
                    iq += 1
            for i in range(n):
                y[i] = y_new[i]
                f[i] = K[S, i]
            t = t_new
            steps += 1
            if store:
                ts[steps] = t
    return 0, steps


@njit(cache=True, error_model="numpy", _nrt=False)
def _evaluate(ts, yo, F, steps, t_query, out):
    """The dense output at each time of ``t_query`` (any order) into ``out`` (m, 7)."""
    for k in range(t_query.shape[0]):
        tq = t_query[k]
        i = np.searchsorted(ts[1:steps + 1], tq)  # the step whose end is the first at or after tq
        if i >= steps:
            i = steps - 1
        _dense_value(F, i, yo[i], (tq - ts[i]) / (ts[i + 1] - ts[i]), out, k)


class DenseSolution:
    """A compiled DOP853 run as a function of time: ``t (m,) -> (q (m, 4) normalised, omega (m, 3))`` anywhere in
    ``[0, duration]``; ``steps`` the steps it took, ``evaluations`` its right-hand-side evaluations (accepted steps)."""

    def __init__(self, ts, yo, F, steps: int, duration: float):
        self.ts, self.yo, self.F, self.steps, self.duration = ts, yo, F, int(steps), float(duration)

    @property
    def evaluations(self) -> int:
        return 15 * self.steps

    def __call__(self, t):
        t = np.ascontiguousarray(np.atleast_1d(np.asarray(t, dtype=float)))
        if t.size and (t.min() < -1e-12 * max(1.0, self.duration) or t.max() > self.duration * (1 + 1e-12) + 1e-12):
            raise ValueError(f"t: expected times within [0, {self.duration:g}] s")
        out = np.empty((len(t), 7))
        _evaluate(self.ts, self.yo, self.F, self.steps, t, out)
        q = out[:, :4] / np.linalg.norm(out[:, :4], axis=1, keepdims=True)
        return q, out[:, 4:]


def _run(inertia, q0, omega0, duration, torque, rtol, atol, max_steps, store, t_query):
    I = np.ascontiguousarray(inertia, dtype=float)
    if torque is None:
        kind, P, T = 0, np.zeros(3), np.zeros((0, 4))
    elif isinstance(torque, TorqueModel):
        torque.check_span(duration)
        kind, P, T = torque.kernel_data()
    else:
        raise TypeError(f"torque: the compiled DOP853 takes a TorqueModel or None, got {type(torque).__name__}")
    breaks = torque.breakpoints(duration) if hasattr(torque, "breakpoints") else ()
    ends = np.array([float(b) for b in np.unique(breaks) if 0 < b < duration] + [float(duration)])
    y0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(omega0, dtype=float)])
    out = np.full((len(t_query), 7), np.nan)
    args = (y0, ends, float(rtol), float(atol), int(max_steps), I, np.linalg.inv(I), int(kind),
            np.ascontiguousarray(P, dtype=float), np.ascontiguousarray(T, dtype=float), _A, _C, _B, _E3, _E5, _D)
    work = np.empty((24, 7))
    stop = compiled_run_flag()  # Ctrl-C stops the run (xcheck.base.interrupts)
    ts, yo, F = np.empty(2), np.empty((1, 7)), np.empty((1, 7, 7))
    for aware in (False, True):  # made aware only where the first run's steps chased their own rounding
        # with ``store``, a first run counts the steps and the second keeps them (a few milliseconds more; no numba
        # runtime); without, the one run is the answer
        status, steps = _solve(*args, aware, False, t_query, out, ts, yo, F, work, stop)
        if status != 6:
            break
    if store and status == 0:
        ts, yo, F = np.empty(steps + 1), np.empty((max(steps, 1), 7)), np.empty((max(steps, 1), 7, 7))
        status, steps = _solve(*args, aware, True, t_query, out, ts, yo, F, work, stop)
    if status == 5:
        raise_stopped()
    if status:
        raise DOP853Failure(f"the compiled DOP853 stopped after {steps} steps of {duration:g} s: "
                           f"{COMPILED_DOP853_STATUS[int(status)]}")
    return steps, ts, yo, F, out


def dop853_at(inertia, q0, omega0, duration: float, times, *, torque=None, rtol: float = 1e-13, atol: float = 1e-15,
              max_steps: int = 1_000_000):
    """DOP853 (compiled) from 0 to ``duration``, its dense output at ``times`` (n,) in ``[0, duration]``, any order:
    ``q`` (n, 4) normalised, ``omega`` (n, 3). Nothing is kept of the run but these values (see :func:`dop853_dense`)."""
    times = np.asarray(times, dtype=float)
    order = np.argsort(times, kind="stable")
    t_query = np.ascontiguousarray(np.clip(times[order], 0.0, float(duration)))
    _, _, _, _, out = _run(inertia, q0, omega0, duration, torque, rtol, atol, max_steps, False, t_query)
    values = np.empty_like(out)
    values[order] = out
    return values[:, :4] / np.linalg.norm(values[:, :4], axis=1, keepdims=True), values[:, 4:]


def dop853_dense(inertia, q0, omega0, duration: float, *, torque=None, rtol: float = 1e-13, atol: float = 1e-15,
                 max_steps: int = 200_000) -> DenseSolution:
    """DOP853 (compiled) on ``[q, omega]`` from 0 to ``duration`` under ``torque`` (None or a
    :class:`~xcheck.fields.TorqueModel`), restarted at the torque's breakpoints like
    :func:`xcheck.reference.dop853_solution`, its dense output kept (456 bytes a step: at most ``max_steps``).
    ``inertia`` (3, 3) [kg m^2], ``q0`` (4,) [w, x, y, z] body -> world, ``omega0`` (3,) [rad/s] body frame: checked
    by the caller. RuntimeError naming the reason when the run stops (:data:`COMPILED_DOP853_STATUS`)."""
    steps, ts, yo, F, _ = _run(inertia, q0, omega0, duration, torque, rtol, atol, max_steps, True, np.zeros(0))
    return DenseSolution(ts, yo, F, steps, duration)


def warm() -> None:
    """Compile (or load from the cache) both kernels: one short run kept, one evaluated (every run has their one
    signature)."""
    inertia = np.diag([1.0, 2.0, 3.0])
    dop853_dense(inertia, [1.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3], 0.1)(np.array([0.05]))
    dop853_at(inertia, [1.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3], 0.1, [0.05])
