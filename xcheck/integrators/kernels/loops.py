"""The loops and the entry points: :func:`run` (a trajectory's steps), the compiled entry points made per scheme
and step on first use (:func:`entry_points`), the lanes' entry points, and the Python-facing :func:`run_one`,
:func:`run_many`, :func:`scratch`."""

from __future__ import annotations

import numpy as np

from . import lanes
from ._variant import PYTHON_MODE, ijit, jit, pjit, prange, stop_requested
from .registry import INTERRUPTED, NONFINITE, OK, SCHEMES
from .schemes import STATE_SIZE, WORK_SIZE
from .lanes import LANES, LANES_OF
from .steps import (RK4_STEP, RK_STEPS, after_step, before_step, cf4_step, lgvi_step, rk_step_for, split2_step,
                    split4_step)


# ------------------------------------------------------------------------------------------------
# the loops and the two entry points
# ------------------------------------------------------------------------------------------------
@ijit
def run(scheme, step_fn, a, y0, I, Iinv, out, K, Y, Yhat, work, y, y_prev):
    """Integrate ``a.n`` steps with ``step_fn`` (a generated RK step, :func:`rk_step_for`, or :func:`cf4_step`) (the last of length
    ``a.last_h``) from ``y0``; store ``y`` every ``a.save_every`` steps and at the end into ``out`` (row 0 =
    ``y0``). ``K, Y, Yhat, work, y, y_prev`` are scratch (:func:`scratch`). Returns (steps done, status): on a
    singular or non-finite step, one over its budget, or a stop asked for (``a.stop``, polled every step:
    INTERRUPTED) the loop stops, and ``out``'s remaining rows hold the last good state."""
    m = STATE_SIZE[scheme]
    for l in range(m):
        y[l] = y0[l]
        out[0, l] = y[l]
    row = 1
    until_save = a.save_every
    n, dt, last_h, save_every, bjorck_tol = a.n, a.dt, a.last_h, a.save_every, a.bjorck_tol
    A, b, c = a.A, a.b, a.c  # the record unpacked once per run
    tk, tP, tT, axes, sing_tol, stop = a.tk, a.tP, a.tT, a.axes, a.sing_tol, a.stop
    for step in range(n):
        h = dt if step < n - 1 else last_h
        t = step * dt
        before_step(scheme, y, bjorck_tol, work)
        for l in range(m):
            y_prev[l] = y[l]
        status = step_fn(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, tk, tP, tT, axes, sing_tol,
                         work)
        if status == OK:
            after_step(scheme, y, bjorck_tol, work)
            for l in range(m):
                if not np.isfinite(y[l]):
                    status = NONFINITE
            if stop_requested(stop):
                status = INTERRUPTED
        if status != OK:  # the last good state fills the remaining rows
            for r in range(row, out.shape[0]):
                for l in range(m):
                    out[r, l] = y_prev[l]
            return step, status
        until_save -= 1
        if until_save == 0 or step == n - 1:
            for l in range(m):
                out[row, l] = y[l]
            row += 1
            until_save = save_every
    return n, OK


def _entry_points(scheme: int, step: str):
    """The two compiled entry points of ``scheme`` stepped by ``step`` (a generated RK step, :func:`rk_step_for`, or
    :func:`cf4_step`), made from the registry: ``run_<name>__<step>(a, y0, I, Iinv, out, K, Y, Yhat, work, y,
    y_prev)`` (the scratch arrays of :func:`run`, allocated by the caller: the loop itself neither allocates nor
    counts references) and ``many_<name>__<step>(a, Y0, I, Iinv, out, steps_done, status, K, Y, Yhat, work, y,
    y_prev)``, which calls the first for each row in parallel threads, each row with its own scratch. The scheme is a
    literal constant and its step function is named in their source (an overload choosing the step doubled the
    compile time). They are compiled from text under this file's name so that numba caches them like functions
    written out here (a closure would miss the cache on every run, and ``numba.literally`` re-types every call: 67
    ms)."""
    ident = SCHEMES[scheme].name.replace("-", "_") + "__" + step
    namespace = {**globals(), **RK_STEPS, "cf4_step": cf4_step, "lgvi_step": lgvi_step, "split2_step": split2_step,
                 "split4_step": split4_step, "prange": prange}
    exec(compile(f"def run_{ident}(a, y0, I, Iinv, out, K, Y, Yhat, work, y, y_prev):\n"
                 f"    return run({scheme}, {step}, a, y0, I, Iinv, out, K, Y, Yhat, work, y, y_prev)\n",
                 __file__, "exec"), namespace)
    one = namespace[f"run_{ident}"] = jit(namespace[f"run_{ident}"])
    exec(compile(f"def many_{ident}(a, Y0, I, Iinv, out, steps_done, status, K, Y, Yhat, work, y, y_prev):\n"
                 f"    for k in prange(Y0.shape[0]):\n"
                 f"        nd, st = run_{ident}(a, Y0[k], I[k], Iinv[k], out[k], K[k], Y[k], Yhat[k], work[k], y[k],\n"
                 f"                             y_prev[k])\n"
                 f"        steps_done[k] = nd\n"
                 f"        status[k] = st\n",
                 __file__, "exec"), namespace)
    return one, pjit(namespace[f"many_{ident}"])


#: The entry points made so far, by (scheme, step): each on first use (:func:`entry_points`).
_ENTRIES: dict = {}


def entry_points(scheme: int, step: str):
    """``(run_one, run_many)`` compiled for ``scheme`` stepped by ``step``, made the first time they are asked for."""
    if (scheme, step) not in _ENTRIES:
        _ENTRIES[scheme, step] = _entry_points(scheme, step)
    return _ENTRIES[scheme, step]


def step_of(scheme: int, tableau, dexp_A=None) -> str:
    """The step function's name of ``scheme`` on ``tableau``: CF4's, the LGVI's or a splitting's own step, or the
    tableau's generated RK step."""
    own = {"cf4": "cf4_step", "lgvi": "lgvi_step", "split2": "split2_step", "split4": "split4_step"}.get(
        SCHEMES[scheme].step)
    return own if own is not None else rk_step_for(tableau, dexp_A)


def _lanes_entry(scheme: int):
    """``lanes_<name>(a, Y0, IL, JL, shared, out, steps_done, status, k0, nb, Y, S, K, Yp, tau, C, q, tout)``:
    :func:`run_lanes` of the scheme for one block of bodies, compiled once, without the interpreter's lock: the
    blocks go to threads of this process (:func:`run_many`). Made from text like :func:`_entry_points`, the
    scheme's lanes functions named in it. (A parallel loop over the blocks compiled in took 5.6 s more to compile
    a scheme for the same speed.)"""
    ident = SCHEMES[scheme].name.replace("-", "_")
    stage, after = LANES_OF[scheme]
    namespace = {**globals(), "run_lanes": lanes.run_lanes, stage: getattr(lanes, stage), after: getattr(lanes, after)}
    exec(compile(f"def lanes_{ident}(a, Y0, IL, JL, shared, out, steps_done, status, k0, nb, Y, S, K, Yp, tau, C, q,\n"
                 f"                tout):\n"
                 f"    run_lanes({scheme}, {stage}, {after}, a, Y0, IL, JL, shared, out, steps_done, status, k0, nb,\n"
                 f"              Y, S, K, Yp, tau, C, q, tout)\n",
                 __file__, "exec"), namespace)
    return jit(namespace[f"lanes_{ident}"])


RUN_LANES = {k: _lanes_entry(k) for k in LANES_OF} if not PYTHON_MODE else {}


def _lanes_blocks(scheme, a, Y0, IL, JL, shared, out, steps_done, status, blocks):
    """The ``blocks`` (indices) of the batch, one after the other, each with fresh scratch."""
    m = STATE_SIZE[scheme]
    scr = (np.zeros((m, LANES)), np.zeros((m, LANES)), np.zeros((4, m, LANES)), np.zeros((m, LANES)),
           np.zeros((3, LANES)), np.zeros((5, LANES)), np.zeros(4), np.zeros(6))
    for b in blocks:
        k0 = b * LANES
        RUN_LANES[scheme](a, Y0, IL, JL, shared, out, steps_done, status, k0, min(LANES, Y0.shape[0] - k0), *scr)


_THREADS: list = []


def _threads():
    """A pool of threads, one a CPU, kept for the process (the lanes release the interpreter's lock)."""
    if not _THREADS:
        import os
        from concurrent.futures import ThreadPoolExecutor

        _THREADS.append(ThreadPoolExecutor(max_workers=os.cpu_count() or 1, thread_name_prefix="xcheck-lanes"))
    return _THREADS[0]


def scratch(scheme, a, *batch):
    """The scratch arrays of :func:`run` (K, Y, Yhat, work, y, y_prev), with leading dimensions ``batch``."""
    m = STATE_SIZE[scheme]
    return (np.zeros((*batch, max(a.b.shape[0], 4), m)),  # CF4 has 4 stages whatever the tableau
            np.zeros((*batch, m)), np.zeros((*batch, m)), np.zeros((*batch, WORK_SIZE[scheme])),
            np.zeros((*batch, m)), np.zeros((*batch, m)))


def run_one(scheme, step, a, y0, I, Iinv, out):
    """One trajectory of ``scheme`` stepped by ``step`` (:func:`run`, :func:`step_of`): (steps done, status, the
    scheme's ``work`` after the run: what its step counted, the LGVI's substeps)."""
    scr = scratch(scheme, a)
    steps, status = entry_points(scheme, step)[0](a, y0, I, Iinv, out, *scr)
    return steps, status, scr[3]


def run_many(scheme, step, a, Y0, I, Iinv, out, steps_done, status):
    """:func:`run` for each row of ``Y0`` (N, m), in parallel threads; ``I``, ``Iinv`` are (N, 3, 3). A scheme with
    lanes on the classical RK4 of its own stage values (not the printed algorithm 172's) runs them instead: the same
    numbers, blocks of bodies in lockstep."""
    if scheme in RUN_LANES and step == RK4_STEP:
        N = Y0.shape[0]
        IL = np.ascontiguousarray(I.reshape(N, 9).T)
        JL = np.ascontiguousarray(Iinv.reshape(N, 9).T)
        shared = bool(np.all(I == I[0]) and np.all(Iinv == Iinv[0]))
        blocks = list(range((N + LANES - 1) // LANES))
        pool = _threads()
        parts = [blocks[i::pool._max_workers] for i in range(pool._max_workers)]
        jobs = [pool.submit(_lanes_blocks, scheme, a, Y0, IL, JL, shared, out, steps_done, status, part)
                for part in parts if part]
        for job in jobs:
            job.result()
        return
    entry_points(scheme, step)[1](a, Y0, I, Iinv, out, steps_done, status, *scratch(scheme, a, Y0.shape[0]))
