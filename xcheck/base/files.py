"""Output paths, checked before any work; atomic writes and stamped folders: a file or folder appears under its
final name only when complete; a folder held by one process at a time."""

from __future__ import annotations

import errno
import json
import os
import shutil
import socket
import tempfile
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path

from .errors import UserError


class OutputPathError(UserError):
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
    """``data`` as JSON (no NaN), written atomically (:func:`json_text`)."""
    write_text_atomic(path, json_text(data))


def json_text(data) -> str:
    """``data`` as JSON text, one entry a line where it nests and the innermost on one line each (a run's metrics,
    a list of numbers): as readable as an indented file and a quarter smaller (a full report's results.json, 3.6 MB
    indented, is 2.8 MB), every number as it is. NaN and infinities are refused (ValueError)."""
    def flat(v) -> bool:
        return not isinstance(v, (dict, list)) or all(not isinstance(x, (dict, list))
                                                      for x in (v.values() if isinstance(v, dict) else v))

    def dump(v, depth: int) -> str:
        if flat(v):
            return json.dumps(v, separators=(",", ":"), allow_nan=False)
        pad = "\n" + " " * (depth + 1)
        if isinstance(v, dict):
            inner = ",".join(pad + _key(k) + ":" + dump(x, depth + 1) for k, x in v.items())
            return "{" + inner + "\n" + " " * depth + "}"
        return "[" + ",".join(pad + dump(x, depth + 1) for x in v) + "\n" + " " * depth + "]"

    return dump(data, 0) + "\n"


def _key(k) -> str:
    """A dict key as JSON writes it (a string; a number, bool or None as its JSON text, quoted)."""
    return json.dumps(k) if isinstance(k, str) else json.dumps({k: 0}, separators=(",", ":"))[1:-3]


def trajectory_csv(comment: str, t, q, omega, attitude_error, euler=None) -> str:
    """A trajectory as CSV text: a ``#`` comment line, a header, then ``t, q (4), omega (3), error`` (and three
    Euler angles if given), 17 significant digits (``%.17g``); a non-finite value (an error where the reference is
    not defined) is an empty field."""
    import math

    import numpy as np

    header = ["t_s", "qw", "qx", "qy", "qz", "wx_rad_s", "wy_rad_s", "wz_rad_s", "attitude_error_rad"]
    cols = [np.asarray(t, dtype=float)[:, None], q, omega, np.asarray(attitude_error, dtype=float)[:, None]]
    if euler is not None:
        header += ["euler1_rad", "euler2_rad", "euler3_rad"]
        cols.append(euler)
    table = np.hstack(cols).astype(float)
    row = ",".join(["%.17g"] * table.shape[1])  # a whole row formatted at once: twice as fast as value by value
    finite = np.isfinite(table).all(axis=1).tolist()
    lines = [f"# {comment}", ",".join(header)]
    lines += [row % tuple(values) if ok else ",".join("%.17g" % v if math.isfinite(v) else "" for v in values)
              for values, ok in zip(table.tolist(), finite)]
    return "\n".join(lines) + "\n"


def write_trajectory_csv(path, comment: str, t, q, omega, attitude_error, euler=None) -> None:
    """:func:`trajectory_csv`, written atomically to ``path``."""
    write_text_atomic(path, trajectory_csv(comment, t, q, omega, attitude_error, euler))


# ------------------------------------------------------------------------------------------------
# stamped folders
# ------------------------------------------------------------------------------------------------
class StampedFolder:
    """``with StampedFolder(out_root) as tmp:`` write into ``tmp``, a hidden ``.incomplete-<stamp>-<host>-<pid>``
    folder; when the block completes it is renamed to ``out_root/<stamp>`` (:attr:`final`; ``<stamp>-2``, ... if
    taken) and ``out_root/latest`` points at it. On any error or interrupt, ``on_failure`` runs first (stopping
    workers whose writes could land later), then the folder is removed, each step to its end despite a
    further Ctrl-C. What killed writers left behind is removed on entry (:func:`remove_stale`). The report and
    a sweep's folder are both written this way."""

    def __init__(self, out_root, *, stamp: str | None = None, on_failure=None):
        self.out_root = Path(out_root)
        self.stamp = stamp or datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
        self.on_failure = on_failure
        self.final: Path | None = None

    def __enter__(self) -> Path:
        self.out_root.mkdir(parents=True, exist_ok=True)
        remove_stale(self.out_root)
        self.tmp = self.out_root / f"{_INCOMPLETE}{self.stamp}-{_owner()}"
        shutil.rmtree(self.tmp, ignore_errors=True)
        try:
            self.tmp.mkdir()
            return self.tmp
        except BaseException:  # an interrupt between the mkdir and the with-block (no __exit__ for it)
            _finish_despite_interrupts(lambda: shutil.rmtree(self.tmp, ignore_errors=True))
            raise

    def __exit__(self, exc_type, exc, tb):
        try:
            if exc_type is None:
                self.final = _rename_into_place(self.tmp, self.out_root, self.stamp)
        except BaseException:
            self._clean_up()
            raise
        if exc_type is not None:
            self._clean_up()
            return False
        _point_latest(self.out_root, self.final)
        return False

    def _clean_up(self) -> None:
        _finish_despite_interrupts(self.on_failure or (lambda: None),
                                   lambda: shutil.rmtree(self.tmp, ignore_errors=True))


def _finish_despite_interrupts(*steps) -> None:
    """Run every cleanup step to its end even when Ctrl-C or SIGTERM arrives during one (SIGTERM is raised as a
    KeyboardInterrupt: with a process group signalled, the workers die first and the parent's own signal can
    land in the middle of removing the folder); the first interrupt is raised again once all are done."""
    pending = None
    for step in steps:
        while True:
            try:
                step()
                break
            except KeyboardInterrupt as exc:  # repeat the step: each is safe to run again
                pending = pending or exc
    if pending is not None:
        raise pending


_INCOMPLETE = ".incomplete-"


def _owner() -> str:
    """``<host>-<pid>``: who is writing a hidden temporary folder or link."""
    host = "".join(c if c.isalnum() else "_" for c in socket.gethostname())[:40] or "host"
    return f"{host}-{os.getpid()}"


def alive(pid: int) -> bool:
    """Whether process ``pid`` runs (on this host)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, but not ours to signal
        return True
    return True


def remove_stale(out_root: Path) -> list[Path]:
    """Remove what killed runs on this host left in ``out_root``: ``.incomplete-*`` folders and ``.latest-*``
    links whose writing process is gone. Returns what was removed."""
    host = _owner().rsplit("-", 1)[0]
    removed = []
    for p in out_root.glob(".*-*"):
        if not (p.name.startswith(_INCOMPLETE) or p.name.startswith(".latest-")):
            continue
        owner_host, _, pid = p.name.rpartition("-")
        if not (pid.isdigit() and owner_host.endswith("-" + host)) or alive(int(pid)):
            continue
        if p.is_symlink() or p.is_file():
            p.unlink(missing_ok=True)
        else:
            shutil.rmtree(p, ignore_errors=True)
        removed.append(p)
    return removed


def _rename_into_place(tmp: Path, out_root: Path, stamp: str) -> Path:
    """Rename ``tmp`` to ``out_root/<stamp>`` or, if another report took that name first, ``<stamp>-2``, ..."""
    for n in range(1, 10_000):
        final = out_root / (stamp if n == 1 else f"{stamp}-{n}")
        if final.exists():
            continue
        try:
            os.rename(tmp, final)
            return final
        except OSError as exc:  # taken between the check and the rename (a concurrent report)
            if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY) and not final.exists():
                raise
    raise OSError(errno.EEXIST, f"no free report name for {stamp} in {out_root}")


def _point_latest(out_root: Path, final: Path):
    link = out_root / "latest"
    tmp_link = out_root / f".latest-{_owner()}"
    try:
        tmp_link.unlink(missing_ok=True)
        tmp_link.symlink_to(final.name, target_is_directory=True)
        os.replace(tmp_link, link)
    except OSError:  # no symlinks here: a text file naming the folder
        tmp_link.unlink(missing_ok=True)
        write_text_atomic(out_root / "latest.txt", final.name + "\n")
