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
