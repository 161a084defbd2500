"""Where a study's tasks run: in this process, in a pool of workers, or shared between the two (the report's
and the converge command's way: this process works beside a pool whose workers import a costly engine)."""

from __future__ import annotations

import threading
from concurrent.futures import FIRST_COMPLETED, as_completed, wait
from itertools import groupby

from ..base.pool import ready_workers, worker_pool
from ..engines import ENGINES, warm_modules
from ..runners import RUNNERS

__all__ = ["map_tasks", "prefer_here", "COLD_WORKER_TASKS"]

#: A worker that has run none of this process's tasks is given one only while more than this many are left.
COLD_WORKER_TASKS = 12


def prefer_here(task) -> bool:
    """The tasks this process takes first when it works beside a pool: not those of an engine whose import
    is costly (:attr:`xcheck.engines.Engine.to_workers`: the workers import it as they start)."""
    engine = ENGINES.get(RUNNERS[task[1][0]].engine)  # None: ours (a task's methods are of one engine)
    return engine is None or not engine.to_workers


def map_tasks(fn, tasks, *, workers, progress, pool, labels, on_result=None, here=None, idle=None):
    """``fn(*task)`` for every task, in ``pool`` (or a pool of its own, or this process for ``workers=1``), calling
    ``record`` as each finishes. ``here``: this process works too, beside the pool (see :func:`_map_here`); a
    predicate that says which tasks it prefers (None: it only waits). ``idle()``: other work this process does
    where it would wait for the workers (it returns whether it found some)."""
    total = len(tasks)
    out = [None] * total
    count = [0]

    def record(i, result):
        out[i] = result
        count[0] += 1
        if on_result:
            on_result(i, result)
        if progress:
            progress(count[0], total, labels[i])

    if pool is None and (workers == 1 or total == 1):
        for i, task in enumerate(tasks):
            record(i, fn(*task))
        return out
    if pool is None:
        with worker_pool(workers) as own:
            return map_tasks(fn, tasks, workers=workers, progress=progress, pool=own, labels=labels, on_result=on_result,
                        here=here, idle=idle)
    if here is not None:
        _map_here(fn, tasks, pool, record, here, idle)
        return out
    futures = {pool.submit(fn, *task): i for i, task in enumerate(tasks)}
    for fut in as_completed(futures):
        record(futures[fut], fut.result())
    return out


def _map_here(fn, tasks, pool, record, prefer, idle=None) -> None:
    """Share ``tasks`` between ``pool`` and this process. The pool takes them from the front of a queue in which
    the tasks this process would rather not run come first (``prefer(task)`` False: those of an engine the
    workers import as they start), kept one task ahead of its workers so that what else is submitted to it, a
    scenario's figures, is not queued behind every study, and given none before one of them has started (a task
    waiting for a worker's imports is better run here); this process takes them from the back, collecting
    finished results between its own, and the workers' own too when more are left than the workers take next. A
    feeder thread sends the workers their next task as each result comes in, while this process runs one of its own;
    results are recorded by this process's thread alone.
    Every process pays its imports and compiled-code loading once (1-3 s): a worker fewer, and this process
    working, is that much less to pay. Where it would wait for the workers, it does ``idle()``'s work first (the
    report's figures of a finished scenario that no worker has started on)."""
    # the workers' own first, their scenarios in the reverse order, as this process takes its own from the back:
    # both go through the scenarios the same way, so that each scenario's study is complete (its figures can be
    # drawn) as soon as both have passed it, not all of them at the very end; within a scenario in the given order
    # (an engine's RK4, its longest runs, before its adaptive methods)
    theirs = [i for i in range(len(tasks)) if not prefer(tasks[i])]
    groups = [list(g) for _, g in groupby(theirs, key=lambda i: id(tasks[i][0]))]  # a task's scenario comes first
    pending = [i for g in reversed(groups) for i in g] + [i for i in range(len(tasks)) if prefer(tasks[i])]
    futures: dict = {}

    def collect() -> None:
        """Record the workers' finished tasks (under ``lock``, in this process's thread)."""
        for fut in [f for f in futures if f.done()]:
            record(futures.pop(fut), fut.result())

    workers = getattr(pool, "_max_workers", 1) or 1
    warm = [False]  # the pool has run one of this process's tasks (and so loaded our compiled code)

    def unfinished() -> int:
        """The workers' tasks not yet done (a done one waits here to be recorded, by this process's thread)."""
        return sum(not f.done() for f in futures)

    def worth_sending() -> bool:
        """One of this process's own tasks goes to a worker only when a worker is idle (queued behind a long run
        of Basilisk's it would finish after this process had run out of work and waited for it), or, once the pool has
        run one and more than twice the workers' number are left, to queue one behind each worker's run (it would
        otherwise wait for this process to finish its own task before it is given the next: the full report's worker
        was busy 7 s of 27 with a task at a time, 11 s with one queued, the report 34 s -> 29 s), and, before
        the pool has run one, only with enough of them left: the first costs a worker the load of our compiled
        code (0.3-0.5 s; a worker that drove Basilisk alone never loaded it), where this process runs one of a
        quick study in 10-20 ms (seen: the last task of a converge stolen, finishing 0.25 s after this one)."""
        ahead = workers if warm[0] and len(pending) > 2 * workers else 0  # one queued behind each worker's run
        if not (ready_workers(pool) and unfinished() < workers + ahead):
            return False
        return warm[0] or sum(prefer(tasks[i]) for i in pending) > COLD_WORKER_TASKS

    lock, wake, ended = threading.Lock(), threading.Event(), threading.Event()

    def woken(_future) -> None:  # a worker's result in, or a worker ready: a worker to feed
        wake.set()

    def send() -> None:
        """Submit what the rules above allow (under ``lock``)."""
        while pending and (unfinished() < workers + 1 if not prefer(tasks[pending[0]]) else worth_sending()):
            i = pending.pop(0)
            warm[0] = warm[0] or prefer(tasks[i])
            fut = pool.submit(fn, *tasks[i])
            futures[fut] = i
            fut.add_done_callback(woken)

    def feed() -> None:
        """The workers' supply while this process runs a task of its own (seconds, for a long one): each result in
        is a worker free, and the next task is sent at once. Before, it was sent only when this process came back
        between its own tasks, and the full report's worker waited for work 22 s of 56 (issue 61)."""
        while True:
            wake.wait()
            wake.clear()
            with lock:
                if ended.is_set():
                    return
                send()

    for started in getattr(pool, "starting", None) or ():
        started.add_done_callback(woken)
    threading.Thread(target=feed, name="xcheck-feeder", daemon=True).start()

    def block() -> None:
        """Wait for one of the workers' tasks to end (its result recorded by the loop, the next sent by the feeder)."""
        with lock:
            waiting = list(futures)
        if waiting:
            wait(waiting, return_when=FIRST_COMPLETED)

    try:
        while True:
            with lock:
                send()
                collect()
                if not pending and not futures:
                    return
                left = len(pending)
                theirs_left = bool(pending) and not prefer(tasks[pending[-1]]) and bool(futures)
            if not left:
                if not (idle and idle()):
                    block()
                continue
            if theirs_left:  # only the workers' own are left
                if idle and idle():  # other work first: one of their tasks here would cost this process the import
                    continue
                if left <= workers:
                    block()  # no more than they take next: wait for them
                    continue
            with lock:
                if not pending:  # the feeder sent the last of them meanwhile
                    continue
                i = pending.pop()
            record(i, fn(*tasks[i]))
    finally:
        with lock:  # no send after this: an interrupted study's pool is being shut down
            ended.set()
        wake.set()


def worker_modules(figures: bool, engines=None) -> tuple:
    """What a worker imports as it starts: the study (and, on a cold compile cache, some of our kernels compiled:
    :func:`xcheck.integrators.precompile_for_worker`), the engines available here
    (:func:`xcheck.engines.warm_modules`; of ``engines`` alone, when given) and matplotlib's plots (``figures``: a
    report's workers, which draw).
    Here, not in the report: a command that draws nothing (converge, horizon) no longer imports the report's
    modules and matplotlib (0.5 s) to name them."""
    return ("xcheck.study", "xcheck.integrators:precompile_for_worker") + warm_modules(engines) + (
        ("xcheck.report.plots",) if figures else ())
