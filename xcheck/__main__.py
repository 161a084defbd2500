"""``python -m xcheck`` and the ``xcheck`` command: :func:`entry`."""

import os
import signal
from contextlib import contextmanager

from .base.exits import stopped_line

_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _before_the_command(signum, frame):  # noqa: ARG001 (a signal handler's signature)
    """Ctrl-C or SIGTERM while the command line is still being imported: nothing has started (no worker, no file),
    so the process ends at once, in the one line of an interrupt during the work (exit 130 or 143)."""
    os.write(2, (stopped_line(128 + signum) + "\n").encode())
    os._exit(128 + signum)


@contextmanager
def quiet_until_imported():
    """Ctrl-C and SIGTERM end the process in one line (:func:`_before_the_command`) for the length of the block,
    the import of the command line (0.1-0.3 s: argparse, the errors, the interrupts' module), before
    ``cli.main`` sets the handlers of the command itself. Without it, a signal there was Python's: a traceback of
    the import and exit -2 (issue 24, item 10; seen on a loaded machine at 0.12 s). The previous handlers are
    restored as the block ends."""
    previous = {sig: signal.signal(sig, _before_the_command) for sig in _SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def entry() -> None:
    with quiet_until_imported():
        from .cli import entry as command
    command()


if __name__ == "__main__":
    entry()
