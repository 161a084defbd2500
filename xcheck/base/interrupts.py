"""Ctrl-C and SIGTERM as exceptions that unwind a command (and clean up) wherever they land, held back where files
must land together, the stop flag that ends a compiled loop when one arrives, and the progress bar that is also where
a swallowed interrupt is raised again.

Python runs a signal's handler only between two of its own instructions: inside a compiled loop (numba's), a Ctrl-C
would wait for the loop to end, hours for a body it cannot step quickly (issue 58). So every long compiled loop polls
:func:`stop_flag` (``xcheck._jit.stop_requested``) and returns, saying it was stopped, once it is set; the compiled code
releases the interpreter's lock, and a thread of this process (:func:`watch_signals`) sets the flag as a signal
arrives, woken by the byte Python's own C handler writes to its wakeup file descriptor. The handler then raises the
interrupt as the loop returns."""

from __future__ import annotations

import signal
import socket
import sys
import threading
import time
from contextlib import contextmanager


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds (and cleans up) like Ctrl-C."""


#: The signal this command received (Ctrl-C's SIGINT or SIGTERM), if any: one that lands inside an import of a
#: compiled module, or inside MuJoCo's or Basilisk's call of ours, reaches us as that module's error
#: ("ImportError: initialization failed", "Python exception raised"), which is then an interrupt all the same.
SIGNALLED: list = []
#: An interrupt raised inside an object's ``__del__`` is printed as "Exception ignored" and lost; it is raised once
#: more this long after the signal, wherever the work is then (the clean-up steps survive a second interrupt).
REPEAT_INTERRUPT = 0.5


#: The stop flag every long compiled loop polls (:func:`stop_flag`), once made: nonzero (the signal's number) once
#: SIGINT or SIGTERM has arrived while one ran.
_FLAG: list = []


def stop_flag():
    """The stop flag: one ``int64`` array of one element for the process (a compiled loop reads the array it is
    handed, so it is passed, never a copy); cleared by :func:`clear_stop` where a run starts from Python. Made on first
    use: this module is imported before the signal handlers are installed, numpy after them."""
    if not _FLAG:
        import numpy as np

        _FLAG.append(np.zeros(1, dtype=np.int64))
    return _FLAG[0]


def compiled_run_flag():
    """The stop flag a compiled run starting from Python is handed: the signals watched (:func:`watch_signals`) and
    the flag cleared (:func:`clear_stop`)."""
    watch_signals()
    clear_stop()
    return stop_flag()


#: The signals that stop a compiled loop (and SIGALRM, :data:`REPEAT_INTERRUPT`'s repeat, once one has arrived).
_STOPPING = {signal.SIGINT, signal.SIGTERM}
#: The watcher's socket pair and thread, once made (:func:`watch_signals`).
_WATCH: dict = {}
#: SIGINT and SIGTERM as they arrived at this process (read by the watcher thread as Python's C handler wrote them,
#: before the main thread runs the Python handler that records them in :data:`SIGNALLED`), for the length of a command.
ARRIVED: list = []


def _watch(sock) -> None:
    """The watcher thread: each byte is a signal's number (written by Python's C-level handler, whatever the main
    thread is doing); SIGINT and SIGTERM set the stop flag."""
    while True:
        try:
            data = sock.recv(64)
        except OSError:
            return
        if not data:
            return
        for signum in data:
            if signum in _STOPPING:
                ARRIVED.append(signum)
            # the flag as it is, never made here: numpy may be half imported by the main thread at this moment
            # (a signal in the command's first second: "module 'numpy' has no attribute 'zeros'"), and a compiled
            # loop runs only once the flag is made and the handler has already raised the interrupt before then
            if _FLAG and (signum in _STOPPING or (signum == getattr(signal, "SIGALRM", -1) and SIGNALLED)):
                _FLAG[0][0] = signum


def watch_signals() -> bool:
    """Have SIGINT and SIGTERM set the stop flag (see the module docstring) from now on, in this process: a wakeup
    file descriptor and a daemon thread reading it, made once. Only from the main thread, and only where nobody else
    (an asyncio loop) has set a wakeup descriptor; False where it could not be. Called as a command starts and as a
    compiled run starts (a library's or the tests' calls are stopped by Ctrl-C too)."""
    if _WATCH:
        return True
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "set_wakeup_fd"):
        return False
    reader, writer = socket.socketpair()
    writer.setblocking(False)
    try:
        previous = signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
    except (ValueError, OSError):
        reader.close(), writer.close()
        return False
    if previous != -1:  # somebody else's: theirs stays
        signal.set_wakeup_fd(previous)
        reader.close(), writer.close()
        return False
    _WATCH.update(reader=reader, writer=writer,
                  thread=threading.Thread(target=_watch, args=(reader,), name="xcheck-stop-watch", daemon=True))
    _WATCH["thread"].start()
    return True


def clear_stop() -> None:
    """A compiled run starting from Python runs until it is stopped again (an interrupt already handled, in a
    notebook or a test, does not stop the next run)."""
    if _FLAG:
        _FLAG[0][0] = 0


def raise_stopped() -> None:
    """A compiled loop returned because the stop flag was set: the interrupt it stands for (Python's own handler has
    usually raised it already, as the loop returned)."""
    if not SIGNALLED:
        SIGNALLED.append(int(stop_flag()[0]) or signal.SIGINT)
    raise as_interrupt()


def _on_sigterm(signum, frame):
    _signalled(signum)
    raise Terminated()


def _on_sigint(signum, frame):
    _signalled(signum)
    raise KeyboardInterrupt()


#: The signal by which a pool's management thread tells the main thread that a worker died (killed from outside, out
#: of memory): the command ends at once, saying so, where it would first finish the runs it was doing itself (MuJoCo's
#: rollout checks for signals between its steps, as it does for Ctrl-C). None where the platform has no SIGUSR1.
WORKER_DIED = getattr(signal, "SIGUSR1", None)
#: Whether the main thread was told a worker died (once a command: every pending task of the pool fails with it).
DIED: list = []


#: How long a worker's death by SIGINT or SIGTERM waits to be seen as this process's own interrupt (the signal sent to
#: the whole process group, which ended the worker) before it is told as a death.
INTERRUPT_GRACE = 0.5


def _interrupted() -> bool:
    return bool(SIGNALLED or ARRIVED)


def worker_died(exitcode=None) -> None:
    """A worker of this command's pool died (called from the thread that watches them, with the worker's exit code):
    raise ``BrokenProcessPool`` in the main thread now, once, unless an interrupt (whose signal reached the workers
    too) is already on its way, or no command's handler is in place (a library's pool: its caller hears it as it
    collects).

    A worker ended by SIGINT or SIGTERM (exit code -2 or -15) is most likely this process's group interrupted: the
    signal reaches this process at the same moment, and the main thread's handler may not have run yet. Python runs
    pending handlers in the order of the signals' numbers, SIGUSR1 (10) before SIGTERM (15), so a death told at once
    was reported instead of the SIGTERM ("a worker process died", exit 3, where 143 was due: seen in the suite).
    Such a death waits up to :data:`INTERRUPT_GRACE` for the signal to be seen here (:data:`ARRIVED`, from the
    watcher thread), and is not told if it is."""
    if WORKER_DIED is None or DIED or signal.getsignal(WORKER_DIED) is not _on_worker_died:
        return
    if exitcode in (-signal.SIGINT, -signal.SIGTERM):
        deadline = time.monotonic() + INTERRUPT_GRACE
        while not _interrupted() and time.monotonic() < deadline:
            time.sleep(0.01)
    if _interrupted():
        return
    DIED.append(True)
    signal.pthread_kill(threading.main_thread().ident, WORKER_DIED)


def worker_death():
    """The error a worker's death is raised as (``BrokenProcessPool``, as the pool itself raises it)."""
    from concurrent.futures.process import BrokenProcessPool

    return BrokenProcessPool("a worker process died")


def _on_worker_died(signum, frame):
    if not _interrupted():  # a Ctrl-C to the whole process group is reported as the interrupt it is
        raise worker_death()


def _signalled(signum) -> None:
    SIGNALLED.append(signum)
    if len(SIGNALLED) == 1 and hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, REPEAT_INTERRUPT)


def _unraisable(hook):
    """``sys.unraisablehook`` for the length of a command: an interrupt that lands in an object's ``__del__`` or in
    a callback from compiled code (llvmlite's object cache, while numba loads) cannot be raised there; it is not
    printed as "Exception ignored" with its traceback, as it is raised again where the work goes on (see
    :data:`REPEAT_INTERRUPT`). Anything else goes to ``hook``."""
    def on_unraisable(unraisable):
        if not _being_reported(unraisable.exc_value):
            hook(unraisable)
    return on_unraisable


def _being_reported(value) -> bool:
    """Whether ``value`` is the interrupt the command is reporting (in one line, not as a traceback)."""
    return isinstance(value, KeyboardInterrupt) and bool(SIGNALLED)


def _excepthook(hook):
    """``sys.excepthook`` for the length of a command: a compiled module whose import calls numpy's ``import_array``
    prints the error that import met with ``PyErr_Print`` (that is, this hook) before it fails with its own
    "numpy._core.multiarray failed to import"; an interrupt landing in that import was printed as a traceback of one
    frame, the handler's (seen in CI: SIGTERM 0.2 s into a report), and is then reported in one line all the same
    (:data:`SIGNALLED`). Anything else goes to ``hook``."""
    def on_exception(kind, value, traceback):
        if not _being_reported(value):
            hook(kind, value, traceback)
    return on_exception


def _on_alarm(signum, frame):
    # an interrupt already on its way out (its clean-up, its message) was not swallowed: raising a second one
    # there would escape the handler that says "interrupted" and end the process by the signal (exit -2)
    if not isinstance(sys.exc_info()[1], KeyboardInterrupt):
        raise_if_signalled()


def raise_if_signalled() -> None:
    """Raise the interrupt again where the work reports progress: one raised inside an object's ``__del__`` (a
    compiled module's, while this process imports or compiles) is printed as "Exception ignored" and the work
    goes on, as if there had been no Ctrl-C."""
    if SIGNALLED:
        raise as_interrupt()
    if DIED:  # a worker's death told while the main thread could not raise it (inside an object's __del__)
        raise worker_death()


def as_interrupt() -> KeyboardInterrupt:
    """The interrupt the received signal stands for (:class:`Terminated` for SIGTERM)."""
    return Terminated() if SIGNALLED and SIGNALLED[0] == signal.SIGTERM else KeyboardInterrupt()


def stop_repeating() -> None:
    """No further repeat of an interrupt (it is being reported)."""
    if hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, 0)


@contextmanager
def signals_as_interrupts():
    """For the length of a command: SIGINT and SIGTERM raise :class:`KeyboardInterrupt` / :class:`Terminated` in
    the main thread (a signal before is not ours), repeated once if swallowed; interrupts in ``__del__`` or in a
    compiled module's import are not printed. Everything is restored as the block ends."""
    previous = None
    SIGNALLED.clear()  # a command run again in the same process (the tests) starts uninterrupted
    ARRIVED.clear()
    DIED.clear()
    clear_stop()
    if threading.current_thread() is threading.main_thread():
        watch_signals()
        previous = [(sig, signal.signal(sig, handler)) for sig, handler in
                    ((signal.SIGTERM, _on_sigterm), (signal.SIGINT, _on_sigint),
                     *(((signal.SIGALRM, _on_alarm),) if hasattr(signal, "SIGALRM") else ()),
                     *(((WORKER_DIED, _on_worker_died),) if WORKER_DIED is not None else ()))]
    previous_hooks = sys.unraisablehook, sys.excepthook
    sys.unraisablehook, sys.excepthook = _unraisable(sys.unraisablehook), _excepthook(sys.excepthook)
    try:
        yield
    finally:
        sys.unraisablehook, sys.excepthook = previous_hooks
        if previous is not None:
            stop_repeating()
            for sig, handler in previous:
                signal.signal(sig, handler)


@contextmanager
def signals_deferred():
    """Ctrl-C and SIGTERM held back for the length of a block (delivered as it ends): files written in it land all
    or none of them, where each alone is atomic (a league's JSON without its Markdown once said "no report was
    written"). Only in the main thread; elsewhere a plain block."""
    held = {signal.SIGINT, signal.SIGTERM}
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


class Progress:
    """``progress(done, total, label)``: a bar on a terminal, nothing otherwise; a swallowed interrupt is raised
    again here."""

    def __init__(self, enabled: bool | None = None, stream=None):
        self.stream = sys.stderr if stream is None else stream  # the stream of now, not of import time (pytest's capsys)
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.start = time.perf_counter()

    def __call__(self, done: int, total: int, label: str = ""):
        raise_if_signalled()
        if not self.enabled:
            return
        width = 30
        filled = int(width * done / max(total, 1))
        elapsed = time.perf_counter() - self.start
        eta = f" ETA {elapsed * (total - done) / done:4.0f}s" if 0 < done < total else ""
        line = f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} {elapsed:5.1f}s{eta} {label}"
        self.stream.write(line[:120].ljust(120))
        self.stream.flush()
        if done >= total:
            self.stream.write("\n")
