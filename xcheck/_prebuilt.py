"""The compiled code a release ships, so that a first run loads its integrators instead of compiling them (issue 61).

numba compiles xcheck's kernels on a machine's first run: about 55 s of CPU for one study's methods, two to three
minutes for the full report. The same compiled code, made once for the release, ships in the package as one archive,
``xcheck/prebuilt/<cache folder>.<Python tag>.numba-<version>.<machine>.tar.xz`` (1-2 MB), and a first run unpacks it
into the user's cache folder (:func:`xcheck._jit.cache_root`, about 0.2 s) where numba finds it as its own cache.

What makes that code fit another machine:

- **The target.** numba compiles for the host CPU by default, and its cache keys every function by the CPU's name and
  features: code made on one machine would never be found on another. xcheck's compiled code is therefore for the
  architecture's generic CPU (numba's ``NUMBA_CPU_NAME=generic``), everywhere, shipped or compiled here: the same
  instructions on every machine. Measured on this project's 2-core machine (Rocket Lake), single trajectories run at
  the host's speed (within 5 %, either way) and the batch lanes of ``formulation-2`` and ``lie-rkmk4`` ~15 % slower
  (4.5e7 against 5.2e7 body-steps/s, their goal 3e7); the numbers are bit for bit the host's (numba contracts no
  multiply-adds without ``fastmath``).
- **The sources.** The cache folder's name carries a hash of the compiled sources (:data:`xcheck._jit.COMPILED_SOURCES`)
  and numba's index a hash of each file: an archive made from other sources is not used (the folder's name differs).
- **Python and numba.** numba's files name the Python version and its index numba's: the archive's name says both,
  and one that does not fit this interpreter is not unpacked. Then xcheck compiles as before, once per release.

``XCHECK_NATIVE=1`` compiles for this machine's own CPU instead (a cache folder of its own, the shipped code unused),
and so does a process where the user chose numba's CPU (``NUMBA_CPU_NAME``, ``NUMBA_CPU_FEATURES``), keeps numba's own
cache (``NUMBA_CACHE_DIR``), or compiled something with numba before importing xcheck.

``python tools/build_prebuilt.py`` makes the archive (the full report and the test suite, compiled into an empty cache,
then packed); ``tests/test_prebuilt.py`` fails while the archive is not this commit's sources'.
"""

from __future__ import annotations

import lzma
import os
import platform
import shutil
import sys
import tarfile
from pathlib import Path

__all__ = ["FOLDER", "TARGET", "native_wanted", "choose_target", "archive_name", "archive_for", "unpack", "pack"]

#: Where the archives ship (package data).
FOLDER = Path(__file__).resolve().parent / "prebuilt"
#: numba's CPU name for xcheck's compiled code (its CPU features: none beyond the architecture's baseline).
TARGET = "generic"


def _native_asked() -> bool:
    return os.environ.get("XCHECK_NATIVE", "") not in ("", "0")


def native_wanted(config, context_made: bool) -> bool:
    """Whether this process compiles for the host CPU (see the module docstring): ``XCHECK_NATIVE=1``, numba's CPU or
    cache folder chosen by the user (``config``: ``numba.core.config``; ``NUMBA_CPU_NAME=generic`` with no features is
    xcheck's own choice, which its processes hand down to theirs), or numba's CPU context made already."""
    return (_native_asked() or config.CPU_NAME not in (None, TARGET)
            or config.CPU_FEATURES not in (None, "") or bool(config.CACHE_DIR) or context_made)


def choose_target(config, context_made: bool) -> bool:
    """Set numba's CPU for this process (generic, or the host's: :func:`native_wanted`), in ``config`` and in the
    environment, where numba reads it again whenever a ``NUMBA_`` variable changes and child processes inherit it;
    True where generic. ``XCHECK_NATIVE=1`` undoes a generic CPU inherited from an xcheck parent."""
    if not native_wanted(config, context_made):
        os.environ["NUMBA_CPU_NAME"], os.environ["NUMBA_CPU_FEATURES"] = TARGET, ""
        config.CPU_NAME, config.CPU_FEATURES = TARGET, ""
        return True
    if (_native_asked() and not context_made
            and os.environ.get("NUMBA_CPU_NAME") == TARGET and not os.environ.get("NUMBA_CPU_FEATURES")):
        os.environ.pop("NUMBA_CPU_NAME")
        os.environ.pop("NUMBA_CPU_FEATURES", None)
        config.CPU_NAME = config.CPU_FEATURES = None
    return False


def archive_name(root_name: str, numba_version: str) -> str:
    """The archive of the cache folder ``root_name`` for this interpreter, numba and machine."""
    return f"{root_name}.{sys.implementation.cache_tag}.numba-{numba_version}.{platform.machine()}.tar.xz"


def archive_for(root_name: str, numba_version: str, folder: Path | None = None) -> Path | None:
    """The shipped archive of ``root_name`` that fits this process, else None."""
    path = (folder or FOLDER) / archive_name(root_name, numba_version)
    return path if path.is_file() else None


def unpack(archive: Path, root: Path) -> bool:
    """Unpack ``archive`` as the folder ``root``, whole or not at all: into a hidden sibling, then renamed into place.
    False (and nothing left behind) if ``root`` appeared meanwhile (another process unpacked it: theirs is kept) or
    cannot be written; the caller then compiles as without an archive."""
    tmp = root.parent / f".{root.name}.{os.getpid()}.unpacking"
    try:
        root.parent.mkdir(parents=True, exist_ok=True)
        with tarfile.open(archive, "r:xz") as tar:
            members = tar.getmembers()
            if any(not m.isfile() and not m.isdir() or m.name.startswith(("/", "..")) or "/../" in m.name
                   for m in members):
                return False  # not an archive this module made
            tar.extractall(tmp, members=members, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
        os.rename(tmp, root)
        return True
    except (OSError, EOFError, lzma.LZMAError, tarfile.TarError):  # unwritable, or a damaged archive
        return False
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def pack(root: Path, archive: Path) -> int:
    """Pack the cache folder ``root`` (its numba index and data files) as ``archive``, written atomically; the number
    of files packed."""
    files = sorted(p for p in root.rglob("*") if p.is_file() and p.suffix in (".nbi", ".nbc"))
    tmp = archive.with_name(archive.name + ".tmp")
    archive.parent.mkdir(parents=True, exist_ok=True)
    with tarfile.open(tmp, "w:xz", preset=9) as tar:
        for p in files:
            info = tar.gettarinfo(p, p.relative_to(root).as_posix())
            info.mtime, info.uid, info.gid, info.uname, info.gname, info.mode = 0, 0, 0, "", "", 0o644
            with open(p, "rb") as f:
                tar.addfile(info, f)
    os.replace(tmp, archive)
    return len(files)
