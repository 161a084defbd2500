"""The MuJoCo version matrix of ``xcheck nightly --mujoco 3.2.7,3.6.0,4.0.0`` (issue 11).

Each release other than the installed one runs in its own virtual environment, made once with the ordinary
tools (``python -m venv``, then ``pip install mujoco==X``) and cached under the user cache
(``$XCHECK_CACHE_DIR``, else ``~/.cache/xcheck``: ``mujoco-envs/py3.11-mujoco-3.6.0``). The environment
holds MuJoCo and what it alone needs; everything else (xcheck itself, numpy, scipy, numba, matplotlib) comes
from the environment xcheck runs in, through a ``.pth`` file (so the cache is kept per running environment: its
folder's name ends in a digest of that environment's path and pins; one whose environment is gone is deleted), and pip is held to those versions by a
constraints file: only MuJoCo differs between the columns of the version table, and the numba cache is shared.
In each environment ``python -m xcheck report`` writes the report into ``<out>/mujoco-<X>/``.

A release the package index does not hold is refused before any work (:func:`check_on_index`); one that cannot
be installed (no wheel for this Python or platform — MuJoCo is never built from source here, a build of minutes that
needs its toolchain —, a dependency that conflicts with the pinned versions) is reported as such, with pip's reason;
the others run.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from ..base.errors import UserError
from ..base.files import alive
from ..base.packages import NOT_INSTALLED, package_version
from .store import utc_now

#: What an environment takes from the running one, pinned (MuJoCo may not pull other versions in).
PINNED = ("numpy", "scipy", "numba", "llvmlite", "matplotlib")
_RELEASE = re.compile(r"^(0|[1-9]\d*)\.(0|[1-9]\d*)\.(0|[1-9]\d*)$")  # as PyPI spells them: no leading zeros


class MatrixError(UserError):
    """A version that cannot be installed or run; the message says why."""


def parse_versions(text: str) -> list[str]:
    """``"3.2.7, 4.0.0"`` -> ``["3.2.7", "4.0.0"]``; ``"releases"``: the newest patch of every minor release from 3.2
    to 4.0 (:data:`xcheck.engines.findings.RELEASES`); ValueError naming ``--mujoco`` for anything else."""
    from ..engines.findings import RELEASES, release_key

    if text.strip() == "releases":
        return list(RELEASES)
    items = [v.strip() for v in text.split(",")]
    if not any(items):
        raise ValueError(f"--mujoco: expected a comma-separated list of MuJoCo releases, got {text!r}")
    if not all(items):
        raise ValueError(f"--mujoco: an empty item in {text!r}; expected releases separated by single commas")
    for v in items:
        if not _RELEASE.match(v):
            raise ValueError(f"--mujoco: {v!r} is not a release number like 3.2.7")
    if len(set(items)) < len(items):
        raise ValueError(f"--mujoco: a release is given more than once ({text})")
    return sorted(items, key=release_key)


#: Seconds the package index has to say which MuJoCo releases it holds.
INDEX_SECONDS = 60


def check_on_index(versions: list[str]) -> str | None:
    """Refuse, before any work, releases the package index does not hold (``--mujoco 99.0.0`` once made nothing and
    exited 0): :class:`MatrixError` naming them and the index's newest. The index is asked through pip (``pip
    index versions mujoco``); where it cannot answer, a note saying so is returned and each release's install
    reports for itself."""
    if all(v == installed_mujoco() for v in versions):
        return None
    try:
        proc = subprocess.run([sys.executable, "-m", "pip", "index", "versions", "mujoco", "--disable-pip-version-check",
                               "--no-input"], capture_output=True, text=True, timeout=INDEX_SECONDS)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"note: the package index was not asked which MuJoCo releases it holds ({exc}); installing each"
    found = re.search(r"Available versions:\s*(.+)", proc.stdout)
    if proc.returncode != 0 or not found:
        return (f"note: the package index did not say which MuJoCo releases it holds ({_reason(proc.stderr)}); "
                "installing each")
    held = {v.strip() for v in found.group(1).split(",")}
    missing = [v for v in versions if v not in held and v != installed_mujoco()]
    if missing:
        newest = sorted((v for v in held if _RELEASE.match(v)), key=lambda v: tuple(map(int, v.split("."))))[-3:]
        raise MatrixError(f"--mujoco: {', '.join(missing)} {'is' if len(missing) == 1 else 'are'} not on the package "
                          f"index (its newest: {', '.join(reversed(newest))})")
    return None


def installed_mujoco() -> str | None:
    version = package_version("mujoco")
    return None if version == NOT_INSTALLED else version


def _parent() -> str:
    """The running environment's packages folder, which a release's environment reads through its ``.pth`` file."""
    return sysconfig.get_paths()["purelib"]


def _pins() -> list[str]:
    return [f"{p}=={package_version(p)}" for p in PINNED if package_version(p) != NOT_INSTALLED]


def env_dir(version: str) -> Path:
    """The cached environment of MuJoCo ``version`` for the running environment: two virtual environments (or one
    whose numpy changed) never share one, since each release's environment reads the packages of the one that made
    it (a cache keyed by Python and MuJoCo alone once ran a deleted environment's xcheck, or nothing)."""
    import hashlib

    from .._jit import user_cache_home

    digest = hashlib.sha256("\n".join([_parent(), *_pins()]).encode()).hexdigest()[:10]
    return (user_cache_home() / "mujoco-envs"
            / f"py{sys.version_info[0]}.{sys.version_info[1]}-mujoco-{version}-{digest}")


def prune_envs(root: Path | None = None) -> list[Path]:
    """Delete the cached release environments whose running environment is gone (the ``.pth`` file's folder), and
    half-made ones (a ``.<name>.<pid>`` folder whose maker no longer runs: killed outright while installing);
    returns what was deleted."""
    from .._jit import user_cache_home

    root = user_cache_home() / "mujoco-envs" if root is None else Path(root)
    gone = []
    for p in sorted(root.glob("*")) if root.is_dir() else []:
        if not p.is_dir() or p.is_symlink():
            continue
        half = re.match(r"^\..*\.(\d+)$", p.name)
        if half:
            stale = not alive(int(half.group(1)))
        else:
            pth = next(p.glob("lib*/python*/site-packages/xcheck_parent_environment.pth"), None)
            parent = re.search(r"addsitedir\((['\"])(.*)\1\)", pth.read_text()) if pth else None
            stale = parent is not None and not Path(parent.group(2)).is_dir()
        if stale:
            shutil.rmtree(p, ignore_errors=True)
            gone.append(p)
    return gone


def _python(env: Path) -> Path:
    return env / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def ensure_env(version: str, log=print) -> Path:
    """The Python of the cached environment for MuJoCo ``version``, made when missing (in a temporary folder,
    renamed into place when complete: two nightlies making the same environment do not meet half-made ones; and under
    a lock, so that the second waits for the first's instead of making its own). :class:`MatrixError` with pip's
    reason when it cannot be made."""
    env = env_dir(version)
    if (env / ".ready").is_file():
        return _python(env)
    env.parent.mkdir(parents=True, exist_ok=True)
    prune_envs(env.parent)
    with _making(env):  # another process making the same environment: wait for it instead of making a second
        if (env / ".ready").is_file():
            return _python(env)
        return _make_env(env, version, log)


@contextmanager
def _making(env: Path):
    """An exclusive lock on the making of ``env`` (``fcntl.flock`` on a file beside it; none where there is no fcntl:
    the temporary folder and the rename below still keep two makers apart)."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    with open(env.parent / f".{env.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _make_env(env: Path, version: str, log) -> Path:
    tmp = env.parent / f".{env.name}.{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    log(f"MuJoCo {version}: making its environment in {env} (once)")
    try:
        subprocess.run([sys.executable, "-m", "venv", str(tmp)], check=True, capture_output=True, text=True)
        py = _python(tmp)
        site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                              check=True, capture_output=True, text=True).stdout.strip()
        parent = _parent()
        # the running environment after the new one's own packages (its .pth files too: an editable xcheck)
        Path(site, "xcheck_parent_environment.pth").write_text(f"import site; site.addsitedir({parent!r})\n")
        (tmp / "constraints.txt").write_text("\n".join(_pins()) + "\n")
        pip = subprocess.run([str(py), "-m", "pip", "install", "--disable-pip-version-check", "--no-input", "-q",
                              "-c", str(tmp / "constraints.txt"), "--only-binary", "mujoco", f"mujoco=={version}"],
                             capture_output=True, text=True)
        if pip.returncode != 0:
            raise MatrixError(f"cannot be installed: {_reason(pip.stderr)}")
        check = subprocess.run([str(py), "-c", "import mujoco, xcheck; print(mujoco.__version__)"],
                               capture_output=True, text=True)
        if check.returncode != 0 or check.stdout.strip() != version:
            raise MatrixError(f"installed but does not import: {_reason(check.stderr) or check.stdout.strip()}")
        (tmp / ".ready").write_text(version + "\n")
        try:
            os.rename(tmp, env)
        except OSError:  # another nightly finished it first
            if not (env / ".ready").is_file():
                raise
        return _python(env)
    except subprocess.CalledProcessError as exc:
        raise MatrixError(f"cannot make a virtual environment: {_reason(exc.stderr)}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _reason(stderr: str) -> str:
    lines = [ln.strip() for ln in (stderr or "").splitlines() if ln.strip() and not ln.startswith("WARNING")]
    errors = [ln for ln in lines if "error" in ln.lower()]
    return (errors or lines or ["(no message)"])[-1][:300]


@dataclass
class VersionRun:
    version: str
    results: dict | None  # the report's results.json document, None when it did not run
    note: str  # what happened, for the version table
    folder: Path | None = None  # the report folder


def run_version(version: str, scenarios: list[str], out_root: Path, *, quick: bool, workers: int | None,
                log=print) -> VersionRun:
    """The report of ``scenarios`` against MuJoCo ``version`` in its environment, into
    ``out_root/mujoco-<version>/``."""
    try:
        py = ensure_env(version, log)
    except MatrixError as exc:
        return VersionRun(version, None, str(exc))
    root = Path(out_root) / f"mujoco-{version}"
    cmd = [str(py), "-m", "xcheck", "report", *scenarios, "--out", str(root)]
    cmd += ["--quick"] if quick else []
    cmd += ["--workers", str(workers)] if workers else []
    log(f"MuJoCo {version}: xcheck report in its environment")
    before = latest_report(root)
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    folder = latest_report(root)
    if proc.returncode not in (0, 1) or folder is None or folder == before:
        return VersionRun(version, None, f"the report did not complete (exit {proc.returncode}: "
                                         f"{_reason(proc.stderr)})")
    results = json.loads((folder / "results.json").read_text())
    return VersionRun(version, results, "passed" if results["passed"] else "some checks failed", folder)


def latest_report(root: Path) -> Path | None:
    """The report folder ``root/latest`` points to (or ``latest.txt`` names), if it holds a results.json."""
    root = Path(root)
    link, text = root / "latest", root / "latest.txt"
    folder = link.resolve() if link.exists() else (root / text.read_text().strip() if text.is_file() else None)
    return folder if folder is not None and (folder / "results.json").is_file() else None


def run_matrix(versions: list[str], scenarios: list[str], out_root: Path, *, quick: bool, workers: int | None,
               log=print) -> list[tuple[VersionRun, str, str]]:
    """:func:`run_version` for every release in ``versions`` but the installed one (the running environment's
    own report covers it): ``[(run, started, finished)]`` with UTC ISO times."""
    runs = []
    for v in versions:
        if v == installed_mujoco():
            continue
        started = utc_now()
        vr = run_version(v, scenarios, out_root, quick=quick, workers=workers, log=log)
        log(f"MuJoCo {v}: {vr.note}" + (f" ({vr.folder}/index.html)" if vr.folder else ""))
        runs.append((vr, started, utc_now()))
    return runs
