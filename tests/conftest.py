"""Shared test configuration.

Hypothesis runs derandomized (a fixed seed per test) so that every run of the suite checks the same
examples: results are reproducible, and a failure seen once is seen again.
"""

from hypothesis import HealthCheck, settings

settings.register_profile(
    "xcheck",
    derandomize=True,
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("xcheck")

# xcheck's compiled code is cached per user (xcheck._jit): pytester gives the suites it runs a HOME of their own,
# where an empty cache would recompile every kernel (10-15 s a test). Every process of the suite shares the cache of
# the user who runs it, unless $XCHECK_CACHE_DIR already names one (CI names an empty one for a newcomer's run).
import os  # noqa: E402

from xcheck._jit import user_cache_home  # noqa: E402

os.environ.setdefault("XCHECK_CACHE_DIR", str(user_cache_home()))

import subprocess  # noqa: E402
import sys  # noqa: E402

# Python's bytecode, written by the suite's processes and read by the next ones: README line 2 installs xcheck
# editable, so pip compiled none of it, and where PYTHONDONTWRITEBYTECODE is set (this machine's CI sets it) each of
# the suite's ~200 processes (its workers, the commands it runs, their pools' workers) compiled xcheck's modules again
# from their source: 0.1 s of CPU a process, 188 -> 177 s of the suite's wall time. Into __pycache__ beside the
# sources, as Python does by default (ignored by git); the user's setting holds outside the suite.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False

import pytest  # noqa: E402

#: An older MuJoCo release the version matrix and the release table install (its free-body RK4 is second order)
OLD_MUJOCO = "3.2.7"


@pytest.fixture(scope="session")
def package_index():
    """The package index, reachable: the version matrix and the release table install MuJoCo releases from it;
    skipped, saying so, where it is not."""
    probe = os.path.join(os.path.expanduser("~"), ".cache", "xcheck-pip-probe")
    proc = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--disable-pip-version-check", "-q",
                           "-d", probe, f"mujoco=={OLD_MUJOCO}"], capture_output=True, text=True, timeout=300)
    if proc.returncode != 0:
        pytest.skip(f"the package index is not reachable (pip download mujoco=={OLD_MUJOCO} failed): the version "
                    "matrix needs it to install MuJoCo releases")


#: The core's tests (issue 61's quick inner loop, ``pytest -m core``): the math, the integrators, the references and
#: their checks against independent truths, the metrics and invariants, the bodies, torques and scenarios as data,
#: the study's judgement and the house's layers, without the whole commands run in processes of their own (reports,
#: nightlies, sweeps, signals, engines), and the layers (test_structure). Under 60 s on two cores; the whole suite
#: stays README line 2.
CORE = frozenset(f"test_{name}.py" for name in (
    "rotations", "integrators", "reference", "reference_properties", "truth", "metrics", "invariants", "trajectory",
    "body", "fields", "surface_torques", "gravity_gradient", "seeds", "split", "lgvi", "heavy_top", "gyrostat",
    "study", "study_store", "results", "json_text", "scoring", "determination", "your_step", "timing_and_advice",
    "models", "scenario", "sweep_spec", "sensing", "implicitfast_damping", "structure", "motion", "advice"))


def pytest_collection_modifyitems(config, items):
    """Every test of a :data:`CORE` file is marked ``core``."""
    for item in items:
        if item.path.name in CORE and item.path.parent.name == "tests":
            item.add_marker(pytest.mark.core)


def pytest_configure(config):
    """On an empty compile cache (the suite run first on a machine, before any report), compile the integrators'
    kernels once, in two processes, before the workers start: otherwise every worker's first tests compile the same
    kernels at the same time (25 s of CPU each, the same work twice; 170 -> 153 s wall here). And the bundled
    scenarios' items read the quick report's studies (:class:`_BundledItemsReadTheStore`)."""
    config.pluginmanager.register(_BundledItemsReadTheStore(), "xcheck-suite-study-store")
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return  # a worker, or a run without xdist: each compiles what it needs
    from xcheck.integrators import METHODS, compile_cache_is_cold

    if not compile_cache_is_cold():
        return
    names = [m for m, info in METHODS.items() if info.kernel is not None]
    halves = [names[0::2], names[1::2]]
    warm = ["from xcheck.integrators.dop853 import warm; warm()", ""]  # the guard's DOP853 (issue 36), in one of them
    procs = [subprocess.Popen([sys.executable, "-c", f"from xcheck.integrators import precompile; precompile({h!r}); {w}"])
             for h, w in zip(halves, warm)]
    for p in procs:
        p.wait()


def _session_root(tmp_path_factory):
    """The folder every process of this pytest run shares: with xdist, the parent of the workers' own base
    folders (``pytest-N/popen-gw0`` and ``popen-gw1`` share ``pytest-N``); without it, the run's base folder."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def shared_result(tmp_path_factory, name: str, make):
    """``make(folder)`` (which returns a JSON-able value) computed once per pytest run, whichever of its processes
    asks first, the others waiting on a lock and then reading the value (the suite's costly fixtures, issue 61:
    "compute each expensive fixture once"). ``folder`` is the shared folder ``make`` writes into; the value is kept
    beside it, written only once ``make`` returned, so that a process that sees it sees a finished folder."""
    import fcntl
    import json

    root = _session_root(tmp_path_factory)
    folder, value = root / name, root / f"{name}.json"
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
        if not value.exists():
            folder.mkdir(exist_ok=True)
            result = make(folder)
            value.with_suffix(".partial").write_text(json.dumps(result))
            value.with_suffix(".partial").rename(value)
    return folder, json.loads(value.read_text())


@pytest.fixture(scope="session")
def bundled_quick_report(tmp_path_factory):
    """``xcheck report --quick --trajectories`` of every bundled scenario, in a process of its own, once per pytest
    run (test_cli's checks of the main job, test_history's stored report): ``(proc, out)``, ``proc`` the finished
    command (its return code, stdout and stderr), ``out`` the ``--out`` folder. Read it; do not change it."""
    return _bundled_quick_report(tmp_path_factory)


def _bundled_quick_report(tmp_path_factory):
    """:func:`bundled_quick_report`'s value, made by whichever process of the run asks first (a test of test_cli, or
    the first bundled scenario's item: :class:`_BundledItemsReadTheStore`); its studies are kept in the run's store."""
    def make(folder):
        proc = subprocess.run([sys.executable, "-m", "xcheck", "report", "--quick", "--trajectories", "--out",
                               str(folder / "reports")], capture_output=True, text=True,
                              env={**os.environ, STUDY_STORE: str(_studies(tmp_path_factory))})
        return {"args": proc.args, "returncode": proc.returncode, "stdout": proc.stdout, "stderr": proc.stderr}

    folder, done = shared_result(tmp_path_factory, "bundled-quick-report", make)
    return subprocess.CompletedProcess(**done), folder / "reports"


from xcheck.study.store import ENV as STUDY_STORE  # noqa: E402


def _studies(tmp_path_factory):
    """The folder where this pytest run's quick report keeps its studies (:mod:`xcheck.study.store`)."""
    return _session_root(tmp_path_factory) / "studies"


class _BundledItemsReadTheStore:
    """The bundled scenarios' own items (the plugin's, ``models/scenarios/*.toml``) judge the study the quick report
    (:func:`bundled_quick_report`) ran of the same scenario: the same study, asked twice in a run of the suite, is
    run once (issue 61). The first of them makes the report if no process has yet, or waits for the one making it
    (xdist hands out these files first, having the most items; the report's own two workers keep both cores busy
    meanwhile). A study the report could not keep (it failed; a selection of methods) the item runs, as the plugin
    does for a user. The store is set for these items alone, for the length of their call: no process the suite
    starts sees it. Registered as a plugin (:func:`pytest_configure`): a conftest's hooks reach only items below it."""

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_call(self, item):
        from xcheck.pytest_plugin import CheckItem

        if not (isinstance(item, CheckItem) and item.path.parent == item.config.rootpath / "models" / "scenarios"):
            yield
            return
        _bundled_quick_report(item.config._tmp_path_factory)
        os.environ[STUDY_STORE] = str(_studies(item.config._tmp_path_factory))
        try:
            yield
        finally:
            os.environ.pop(STUDY_STORE, None)
