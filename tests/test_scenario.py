"""Scenario files (xcheck.scenario) become the numbers their seeds give: seed 001's Euler angles and rates
through its own formula (appendix A, velocidade_angular), seed 004's printed quaternion; names are identifiers;
default steps adapt to short durations."""

import numpy as np
import pytest

from xcheck.scenario import (
    DEFAULT_STEPS,
    QUICK_STEPS,
    bundled_scenarios,
    check_name,
    resolve_scenario,
)


def test_every_bundled_scenario_loads():
    names = list(bundled_scenarios())
    assert names == ["boxes-complex", "boxes-simple", "cubesat-parts-orbit-field", "gyroscope-near-singular",
                     "gyroscope-nonsingular",
                     "gyroscope-singular", "gyrostat-axisymmetric", "heavy-top-looping", "heavy-top-near-vertical",
                     "heavy-top", "nesc-tumbling-brick", "rax1-body-field", "rax1-field-gravity-gradient",
                     "rax1-momentum-bias", "rax1-orbit-field",
                     "tumbler-intermediate-axis", "tumbler-three-wheels"]
    for n in names:
        sc = resolve_scenario(n)
        assert sc.name == n and np.linalg.norm(sc.q0) == pytest.approx(1, abs=1e-15) and sc.duration > 0


def test_gyroscope_initial_state_is_seed_001s():
    """Truth: seed 001 appendix A with psi = phi = 0, theta = 15 deg and rates [0.02, 0.02, 15.71] rad/s:
    q = Ry(15 deg) and w = [-psi' s(theta), theta', phi' + psi' c(theta)]."""
    sc = resolve_scenario("gyroscope-nonsingular")
    th = np.radians(15.0)
    np.testing.assert_allclose(sc.q0, [np.cos(th / 2), 0, np.sin(th / 2), 0], atol=1e-15)
    np.testing.assert_allclose(sc.omega0, [-0.02 * np.sin(th), 0.02, 15.71 + 0.02 * np.cos(th)], rtol=1e-14)
    assert sc.steps == DEFAULT_STEPS and sc.quick_steps == QUICK_STEPS and sc.reference == "exact"


def test_rax1_uses_the_printed_quaternion():
    """Truth: seed 004 eq. 178, p = [-0.4583, -0.6558, 0.5997, 0.0182] (scalar first), normalised."""
    sc = resolve_scenario("rax1-body-field")
    p = np.array([-0.4583, -0.6558, 0.5997, 0.0182])
    np.testing.assert_allclose(sc.q0, p / np.linalg.norm(p), atol=1e-15)
    assert sc.torque["kind"] == "magnetic" and sc.torque["field"] == "body-table"


@pytest.mark.parametrize("name", ["gyro", "rax1-orbit-field", "a.b_c-1", "X" * 100])
def test_identifiers_are_names(name):
    assert check_name(name) is None


@pytest.mark.parametrize("name", ["", "../x", "a/b", "a\\b", "..", "a..b", ".x", "-x", "x" * 101, "a b", "é"])
def test_non_identifiers_are_refused(name):
    assert "expected an identifier" in check_name(name)
