"""Where tasks run, behind one small interface (``submit``, ``as_completed``, ``name``): this process, a pool of
worker processes (:mod:`.pool`), or a Dask cluster (a ``--scheduler`` address, or a ``LocalCluster``). The sweep runs
its chunks on one (:func:`xcheck.sweep.run.run_cells`); the same functions on each, so the same results, only the
wall times differ. A study's tasks are mapped by :func:`xcheck.study.executor.map_tasks`, which also decides which run
here (Basilisk's) and needs only the pool."""

from __future__ import annotations

import os
import signal
from contextlib import ExitStack, contextmanager

from .errors import UsageError
from .pool import interrupts_deferred, spawned_with_sigint_blocked, worker_pool

__all__ = ["executor", "SCHEDULER_SECONDS"]


class _Deferred:
    """A task of the in-process executor, run when its result is asked for (so that the log and the progress
    bar follow each chunk, as with the other executors)."""

    def __init__(self, fn, args):
        self.fn, self.args, self._done, self._value = fn, args, False, None

    def result(self):
        if not self._done:
            self._value, self._done = self.fn(*self.args), True
        return self._value


class _InProcess:
    name = "this process"

    def submit(self, fn, *args):
        return _Deferred(fn, args)

    @staticmethod
    def as_completed(futures):
        for f in futures:
            f.result()
            yield f


class _Pool:
    def __init__(self, pool, jobs):
        self.pool, self.name = pool, f"{jobs} worker processes"

    def submit(self, fn, *args):
        return self.pool.submit(fn, *args)

    @staticmethod
    def as_completed(futures):
        from concurrent.futures import as_completed

        return as_completed(futures)


class _Dask:
    def __init__(self, client, name):
        self.client, self.name = client, name

    def submit(self, fn, *args):
        return self.client.submit(fn, *args, pure=False)

    @staticmethod
    def as_completed(futures):
        from distributed import as_completed

        return as_completed(futures)


def _ready() -> bool:
    return True


@contextmanager
def executor(kind: str = "local", jobs: int = 1, scheduler: str | None = None, *, warm: tuple[str, ...] = ()):
    """``local`` with ``jobs`` 1: this process; ``jobs`` > 1: spawned worker processes (:mod:`.pool`) that import
    ``warm`` as they start. ``dask``: a Dask distributed cluster at ``scheduler``, or a ``LocalCluster`` of ``jobs``
    single-threaded worker processes (MuJoCo's control callback is process-global: one task per process at a
    time). Each has ``submit(fn, *args)`` and ``as_completed(futures)``, and a ``name`` to say."""
    if kind == "local":
        if jobs == 1:
            yield _InProcess()
            return
        with worker_pool(jobs, warm=warm) as pool:
            for f in [pool.submit(_ready) for _ in range(jobs)]:  # started and warmed: the start-up is measured
                f.result()
            yield _Pool(pool, jobs)
        return
    try:
        import logging

        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError("--executor dask needs Dask's distributed package: pip install 'xcheck[distributed]'") from None
    if scheduler:
        _reachable(scheduler)
        try:
            client = Client(scheduler, timeout=30)
        except (OSError, TimeoutError) as exc:
            raise UsageError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler there ({exc})") from None
        with client:
            yield _Dask(client, f"the Dask cluster at {scheduler}")
        return
    with ExitStack() as stack:
        # built whole (a Ctrl-C meanwhile is raised once it stands, and the stack closes it), its workers ignoring
        # Ctrl-C themselves: this process closes them
        with interrupts_deferred(), spawned_with_sigint_blocked():
            cluster = stack.enter_context(LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                                       dashboard_address=None, silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
            stack.push(lambda kind, exc, tb: _kill_workers(cluster) if kind is not None else None)
        yield _Dask(client, f"a Dask LocalCluster of {jobs} workers")


def _kill_workers(cluster) -> None:
    """End a LocalCluster's worker processes at once (an interrupted or failed sweep): a worker inside a cell's
    compiled loop does not answer its nanny's request to close, which then waits seconds before it kills it. Dask's
    notes of the connections that this closes (with tracebacks, at INFO) are expected, and not printed."""
    import logging

    logging.getLogger("distributed").setLevel(logging.CRITICAL)
    for nanny in list(cluster.workers.values()):
        pid = getattr(nanny, "pid", None)
        if pid:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:  # gone already
                pass


def _reachable(address: str) -> None:
    """Refuse at once a ``tcp://host:port`` scheduler address nothing listens on (Dask's client would retry
    for its whole timeout)."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if parts.scheme not in ("tcp", "tls") or not host or not port:
        raise UsageError(f"--scheduler {address}: expected a Dask scheduler address, tcp://host:port")
    if parts.scheme == "tcp":
        try:
            socket.create_connection((host, port), timeout=SCHEDULER_SECONDS).close()
        except OSError as exc:
            raise UsageError(f"--scheduler {address}: no Dask scheduler answers there ({exc.strerror or exc})") from None
        _is_a_scheduler(address)


#: Seconds a ``--scheduler`` has to accept the connection and to answer who it is.
SCHEDULER_SECONDS = 10


def _is_a_scheduler(address: str) -> None:
    """Ask what listens at ``address`` who it is (Dask's ``identity``), within :data:`SCHEDULER_SECONDS`: something
    that accepts the connection but does not speak Dask's protocol (a web server) would otherwise keep Dask's
    client waiting without end (dask/distributed#8071)."""
    import asyncio

    from distributed.comm import connect
    from distributed.core import send_recv

    async def identity():
        comm = await asyncio.wait_for(connect(address, timeout=SCHEDULER_SECONDS), SCHEDULER_SECONDS)
        try:
            return await asyncio.wait_for(send_recv(comm, op="identity"), SCHEDULER_SECONDS)
        finally:
            comm.abort()

    try:
        reply = asyncio.run(identity())
    except (asyncio.TimeoutError, OSError, ValueError, TypeError) as exc:
        raise UsageError(f"--scheduler {address}: something answers there, but not a Dask scheduler within "
                         f"{SCHEDULER_SECONDS} s ({type(exc).__name__}{f': {exc}' if str(exc) else ''})") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        what = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise UsageError(f"--scheduler {address}: a Dask {what}, not a scheduler")
