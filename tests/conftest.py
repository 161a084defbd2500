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


def pytest_configure(config):
    """On an empty compile cache (the suite run first on a machine, before any report), compile the integrators'
    kernels once, in two processes, before the workers start: otherwise every worker's first tests compile the same
    kernels at the same time (25 s of CPU each, the same work twice; 170 -> 153 s wall here)."""
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
