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
