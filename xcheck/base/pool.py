"""Worker processes that never outlive the command that started them.

* Workers are spawned (no state inherited from the parent) and ignore SIGINT: on Ctrl-C the parent stops
  them itself (:func:`stop_pool`), at once, instead of waiting for the runs under way to finish.
* A worker dies with its parent, even when the parent is killed with SIGKILL: on Linux the kernel sends it
  SIGKILL (``PR_SET_PDEATHSIG``); elsewhere a watchdog thread notices the new parent process id. With the
  workers gone, multiprocessing's resource tracker sees its pipe close and exits too.
* A worker that dies while the command runs (killed from outside, out of memory) is heard at once: a thread waits on
  the workers' ends and tells the main thread by a signal (:func:`_watch_workers`).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

__all__ = ["make_pool", "stop_pool", "worker_pool", "ready_workers", "resolved"]

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _die_with_parent(parent_pid: int) -> None:
    """Worker initializer (see the module docstring)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:  # the parent died before the line above took effect
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="xcheck-parent-watch", daemon=True).start()


def make_pool(workers: int | None = None) -> ProcessPoolExecutor:
    """A pool of ``workers`` spawned processes (default and at most: the CPU count; more would only share the CPUs,
    each holding ~55 MB) that die with this process."""
    cpus = os.cpu_count() or 1
    return ProcessPoolExecutor(max_workers=min(workers or cpus, cpus), mp_context=multiprocessing.get_context("spawn"),
                               initializer=_die_with_parent, initargs=(os.getpid(),))


def stop_pool(pool: ProcessPoolExecutor, *, grace: float = 2.0, completed: bool = False) -> None:
    """Stop ``pool`` now: cancel what has not started, terminate the workers (SIGTERM, then SIGKILL after
    ``grace`` seconds) and wait for them, so that nothing they write can land after this returns. ``completed``:
    every task's result was collected, so nothing is left to send to the workers (see the end)."""
    pool.stopping = True  # the ends of these workers are not deaths to tell (_watch_workers)
    procs = list((getattr(pool, "_processes", None) or {}).values())  # the executor's own record of its workers
    # shutdown() forgets these three (it sets them to None), so they are taken first
    wakeup = getattr(pool, "_executor_manager_thread_wakeup", None)
    call_queue = getattr(pool, "_call_queue", None)
    thread = getattr(pool, "_executor_manager_thread", None)
    if not all(f.done() for f in getattr(pool, "starting", ())):
        # a worker still starting (an input refused at once) is killed before the executor closes the pipes it
        # is reading and writing: it printed a traceback of its own (BrokenPipeError) on the way out
        for p in procs:
            p.kill()
        for p in procs:
            p.join(grace)
    # the tasks not yet sent sit in the call queue, whose feeder thread may be blocked writing a large one into the
    # pipe of workers that are gone (this process holds the pipe's other end, so the write never fails): it must
    # not be waited for, by the executor's thread or at exit (seen once: a nightly alive ten minutes after
    # "interrupted"). With every result collected there is nothing left to send, and it is waited for (below).
    if call_queue is not None and not (completed and not getattr(call_queue, "_buffer", True)):
        call_queue.cancel_join_thread()
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + grace
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join(1.0)
    # let the executor's own thread see its workers gone and close its pipes now, not at interpreter exit (where it
    # raced atexit's wake-up of it: "OSError: Bad file descriptor"). Gone for good: as a thread ends, after join()
    # returns, it drops its last references to the queues, whose named semaphores' finalizers then tell
    # multiprocessing's resource tracker they are unlinked; a process that left by os._exit meanwhile
    # (cli.entry) cut that message, and the tracker printed "There appear to be 1 leaked semaphore objects" (2
    # runs in 8). The queue's feeder thread holds one of them the same way.
    feeder = None if getattr(call_queue, "_joincancelled", True) else getattr(call_queue, "_thread", None)
    for t in (thread, feeder):
        if t is not None:
            _ended(t, grace)
    # at exit, concurrent.futures wakes that thread through a pipe the thread closes as it ends, without a lock
    # between the two (Python 3.11): a thread still ending then makes the wake-up write to a closed descriptor,
    # printed as "Exception ignored ... OSError: Bad file descriptor" after our message. The pool is stopped:
    # there is nothing left to wake.
    if wakeup is not None:
        wakeup.wakeup = _quiet(wakeup.wakeup)


def _ended(thread: threading.Thread, timeout: float) -> None:
    """Wait (at most ``timeout`` s) until ``thread`` has ended, its operating-system thread included: join()
    returns once its Python code is done, while it may still be dropping references (running finalizers). On
    Linux the thread is gone when /proc no longer lists it; elsewhere join() is what there is."""
    deadline = time.monotonic() + timeout
    thread.join(timeout)
    native = getattr(thread, "native_id", None)
    if native is None or not sys.platform.startswith("linux") or thread.is_alive():
        return
    task = f"/proc/self/task/{native}"
    while os.path.exists(task) and time.monotonic() < deadline:
        time.sleep(0.0002)


def _quiet(wake):
    def wakeup():
        try:
            wake()
        except OSError:  # its pipe closed by the thread it wakes, which has ended
            pass
    return wakeup


def resolved(value):
    """A task's result: ``value`` itself, or its result where it is a future (work done here or submitted to a pool)."""
    return value.result() if hasattr(value, "result") else value


def ready_workers(pool) -> int:
    """How many of ``pool``'s workers have started (imported their modules); all of them for a pool that was not
    warmed."""
    starting = getattr(pool, "starting", None)
    if starting is None:
        return getattr(pool, "_max_workers", 1) or 1
    return sum(f.done() for f in starting)


def _import(modules) -> None:
    """A worker's start: import each module; ``"module:function"`` also calls that function of it (what a worker
    prepares beyond its imports, :func:`xcheck.integrators.precompile_for_worker`)."""
    import importlib

    for name in modules:
        module, _, function = name.partition(":")
        loaded = importlib.import_module(module)
        if function:
            getattr(loaded, function)()


def _start_workers(pool: ProcessPoolExecutor, modules=()) -> None:
    """Start every worker now (one task each: the pool starts one worker per task), each spawned with SIGINT
    ignored: a spawned process inherits an ignored signal, so a Ctrl-C to the process group cannot kill a worker
    before its initializer has made it ignore SIGINT (it would break the pool). ``pool.starting`` holds those
    tasks: one done is a worker ready.

    On Linux each worker starts with SIGINT blocked instead, by the thread that forks it, for that fork only
    (:func:`spawned_with_sigint_blocked`), and this process's handler is never changed. Ignoring it for the whole
    start lost a Ctrl-C now and then (2 in 12 at 0.2 s into a report): numpy's BLAS threads do not block SIGINT,
    so the kernel could hand the signal to one of them while it was ignored, or Python could find it pending
    while its handler was SIG_IGN."""
    if sys.platform.startswith("linux"):
        # and the interrupt that came meanwhile raised once every worker is spawned and known to the pool: raised
        # inside a spawn (after the fork, before the parent wrote the child its start-up data, or registered it),
        # it left a worker that stop_pool could not see, and that printed a traceback (EOFError, or
        # FileNotFoundError for a semaphore gone) as it started after this process had ended (seen in the suite)
        with interrupts_deferred(), spawned_with_sigint_blocked():
            pool.starting = [pool.submit(_import, modules) for _ in range(pool._max_workers)]
        return
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
    try:
        pool.starting = [pool.submit(_import, modules) for _ in range(pool._max_workers)]
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)


def _watch_workers(pool) -> None:
    """A worker of ``pool`` that dies (killed from outside, out of memory) is heard when this process next collects a
    result, after its own runs, and not at all while the worker had no task: a thread waits on the workers' ends and
    tells the main thread at once (:func:`xcheck.base.interrupts.worker_died`) unless :func:`stop_pool` ended them."""
    from multiprocessing.connection import wait

    from .interrupts import worker_died

    processes = list((getattr(pool, "_processes", None) or {}).values())
    sentinels = [p.sentinel for p in processes]

    def watch():
        ended = wait(sentinels)
        if not getattr(pool, "stopping", False):
            dead = next((p for p in processes if p.sentinel in ended), None)
            worker_died(dead.exitcode if dead is not None else None)

    if sentinels:
        threading.Thread(target=watch, name="xcheck-worker-watch", daemon=True).start()


@contextmanager
def interrupts_deferred():
    """Ctrl-C and SIGTERM held for the length of a block that must not be cut in the middle (a Dask cluster half
    built fails its own close at exit): those that come meanwhile are recorded, and delivered (their handler
    called: the interrupt raised) as the block ends. Main thread only; elsewhere nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list = []
    previous = {sig: signal.signal(sig, lambda signum, frame: held.append(signum))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for signum in held:  # each, in order (a handler that raises, as Ctrl-C's does, ends the replay there)
            if callable(previous[signum]):
                previous[signum](signum, None)


@contextmanager
def spawned_with_sigint_blocked():
    """For the length of a block, every process multiprocessing spawns (from any thread: a Dask cluster spawns its
    workers from its event loop's) starts with SIGINT blocked, as :func:`_start_workers` does for ours: a Ctrl-C
    to the process group then never lands in a worker's imports (a traceback each); this process stops them.

    Only the spawning thread blocks SIGINT, only while it forks: the child inherits that thread's signal mask
    through fork and exec (and no Python blocks or unblocks it at start-up), while this process's disposition
    is never changed. A Ctrl-C meanwhile goes to another thread of this process, or waits, pending, until the
    fork is done; it is never dropped. Ignoring it (SIG_IGN) over the same window lost 2 Ctrl-C in 8 while a
    Dask cluster started on a loaded machine: the fork takes longer there, and a signal that arrives while it
    is ignored is discarded. Linux; elsewhere nothing changes."""
    import multiprocessing.util as mp_util

    if not sys.platform.startswith("linux"):
        yield
        return
    spawn = mp_util.spawnv_passfds

    def blocking(*args, **kwargs):
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            return spawn(*args, **kwargs)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)

    mp_util.spawnv_passfds = blocking
    try:
        yield
    finally:
        mp_util.spawnv_passfds = spawn


@contextmanager
def worker_pool(workers: int | None = None, *, warm: tuple[str, ...] = ()):
    """:func:`make_pool` for the length of a block, stopped at its end (:func:`stop_pool`): at once when the
    block raises or is interrupted; when it completes, every result has been collected and the workers are
    idle, so ending them spares their interpreters' teardown (0.5 s measured, numba and MuJoCo loaded).
    The workers start at once (:func:`_start_workers`); ``warm``: modules each imports then."""
    pool = make_pool(workers)
    completed = False
    try:
        _start_workers(pool, warm)
        _watch_workers(pool)
        yield pool
        completed = True
    finally:
        stop_pool(pool, completed=completed)
