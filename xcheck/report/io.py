"""Output paths, checked before any work, and atomic writes: a file or folder appears under its final name
only when complete."""

from __future__ import annotations

import errno
import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


class OutputPathError(ValueError):
    """An output path that cannot be written; the message names the argument and the path."""


def _usable_folder(folder: Path, what: str) -> None:
    """Create ``folder`` (and its parents) if missing, and check that a file can be written in it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputPathError(f"{what}: {folder} exists and is not a folder") from None
    except NotADirectoryError:
        raise OutputPathError(f"{what}: {folder} cannot be created: a part of that path is a file, not a "
                              "folder") from None
    except OSError as exc:
        raise OutputPathError(f"{what}: cannot create the folder {folder} ({exc.strerror})") from None
    try:
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as exc:
        raise OutputPathError(f"{what}: cannot write in the folder {folder} ({exc.strerror})") from None


def check_output_file(path, what: str, *, suffixes: tuple[str, ...] | None = None) -> Path:
    """Check, before any work, that the file ``path`` can be written (its folder is created if missing).

    ``what`` names the argument in messages (``--json``); ``suffixes`` are the allowed endings
    (``(".png", ".svg")``), matched without regard to case. Raises :class:`OutputPathError`."""
    p = Path(path)
    if not str(path) or str(path).endswith(("/", os.sep)) or p.name in ("", ".", ".."):
        raise OutputPathError(f"{what}: expected a file name, got {str(path)!r}")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise OutputPathError(f"{what}: {p} must end in {', '.join(suffixes)} (the format follows the ending)")
    if p.is_dir():
        raise OutputPathError(f"{what}: {p} is a folder; expected a file")
    _usable_folder(p.parent, what)
    return p


def check_output_dir(path, what: str) -> Path:
    """Check, before any work, that the folder ``path`` exists or can be created and can be written.
    Raises :class:`OutputPathError` naming ``what`` (``--out``)."""
    p = Path(path)
    if not str(path):
        raise OutputPathError(f"{what}: expected a folder, got an empty path")
    if p.exists() and not p.is_dir():
        raise OutputPathError(f"{what}: {p} is a file; expected a folder")
    _usable_folder(p, what)
    return p


@contextmanager
def signals_deferred():
    """Ctrl-C and SIGTERM held back for the length of a block (delivered as it ends): files written in it land all
    or none of them, where each alone is atomic (a league's JSON without its Markdown once said "no report was
    written"). Only in the main thread; elsewhere a plain block."""
    import signal
    import threading

    held = {signal.SIGINT, signal.SIGTERM}
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


class BusyError(OutputPathError):
    """Another live xcheck process holds the folder this run would write into."""


@contextmanager
def held_alone(folder, what: str):
    """Hold ``folder`` for this process for the length of a block, or raise :class:`BusyError` naming ``what`` and
    the process holding it: two sweeps into one ``--out`` once had the second delete the first's live log of cells
    as an interrupted run's. The hold is the kernel's (``flock`` on ``folder/.xcheck.lock``), so a process killed
    outright holds nothing; the lock file stays behind, empty of meaning. Where ``flock`` is missing or the folder
    cannot be written (its writer names that), a plain block."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    path = Path(folder) / ".xcheck.lock"
    try:
        f = open(path, "a+")
    except OSError:  # a folder that cannot be written: what writes in it next names it, as it would without this
        yield
        return
    with f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.seek(0)
            holder = f.read().strip() or "another process"
            raise BusyError(f"{what}: {folder} is in use by {holder} (another xcheck run writing there); wait for it "
                            "to end or give another folder") from None
        f.seek(0)
        f.truncate()
        f.write(f"xcheck process {os.getpid()}")
        f.flush()
        try:
            yield
        finally:
            f.seek(0)
            f.truncate()
            fcntl.flock(f, fcntl.LOCK_UN)


def write_bytes_atomic(path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it into place. An OSError names ``path``
    (the file the user knows of), not the temporary file."""
    path = Path(path)
    tmp = None
    try:
        if path.is_dir():
            raise IsADirectoryError(errno.EISDIR, "is a folder; expected a file (remove or rename it)", str(path))
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a report is for reading
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        if exc.filename == str(path):
            raise
        raise type(exc)(exc.errno, f"{exc.strerror} (writing it in {path.parent})" if exc.strerror else str(exc),
                        str(path)) from None
    except BaseException:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        raise


def write_text_atomic(path, text: str) -> None:
    """:func:`write_bytes_atomic` of ``text`` in UTF-8."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_json_atomic(path, data) -> None:
    write_text_atomic(path, json.dumps(data, indent=1, allow_nan=False) + "\n")


def write_trajectory_csv(path, comment: str, t, q, omega, attitude_error, euler=None) -> None:
    """A trajectory as CSV: a ``#`` comment line, a header, then ``t, q (4), omega (3), error`` (and three
    Euler angles if given), 17 significant digits; a non-finite value (an error where the reference is
    not defined) is an empty field."""
    import numpy as np

    header = ["t_s", "qw", "qx", "qy", "qz", "wx_rad_s", "wy_rad_s", "wz_rad_s", "attitude_error_rad"]
    cols = [np.asarray(t)[:, None], q, omega, np.asarray(attitude_error)[:, None]]
    if euler is not None:
        header += ["euler1_rad", "euler2_rad", "euler3_rad"]
        cols.append(euler)
    lines = [f"# {comment}", ",".join(header)]
    lines += [",".join("" if not np.isfinite(v) else f"{v:.17g}" for v in row) for row in np.hstack(cols)]
    write_text_atomic(path, "\n".join(lines) + "\n")
