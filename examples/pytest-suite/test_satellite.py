"""A hand-written test with xcheck's assertion helpers (the scenario files beside it are tests already)."""

from pathlib import Path

from xcheck.testing import assert_agrees, assert_converges, assert_invariants, assert_matches_reference

HERE = Path(__file__).parent
TUMBLE = HERE / "xcheck_tumble.toml"
ORBIT = HERE / "xcheck_orbit_field.toml"


def test_mujoco_rk4_is_fourth_order_in_our_field():
    assert_converges(ORBIT, method="mujoco-rk4", order=4, tol=0.3)


def test_mujoco_matches_the_exact_tumble_at_our_flight_step():
    assert_matches_reference(TUMBLE, method="mujoco-rk4", dt=0.05, atol=1e-6)


def test_mujoco_agrees_with_xcheck_in_orbit():
    assert_agrees(ORBIT, "mujoco-rk4", "lie-rkmk4", dt=0.1, atol=1e-7)


def test_energy_and_momentum_are_kept():
    assert_invariants(TUMBLE, method="mujoco-rk4", dt=0.05, rtol=1e-8)
