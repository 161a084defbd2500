"""Accuracy metrics (xcheck.metrics) against stated truths: a power law e = C dt^p has observed order p
exactly; the rule drops round-off, pre-asymptotic and floor errors; invariants of a body at rest and in steady
spin are exact."""

import numpy as np
import pytest

from xcheck.metrics import (
    errors_against,
    invariant_changes,
    kinetic_energy,
    observed_order,
    world_momentum,
)
from xcheck.trajectory import Trajectory

DTS = [2.0**-k for k in range(1, 9)]


@pytest.mark.parametrize("p", [1, 2, 4])
def test_power_law_has_its_order(p):
    fit = observed_order(DTS, [1e-3 * dt**p for dt in DTS], floor=1e-30)
    assert fit.order == pytest.approx(p, abs=1e-12) and len(fit.local_orders) == len(DTS) - 1


def test_round_off_floor_and_ceiling_are_dropped():
    errors = [0.5, 0.2] + [1e-4 * dt**4 for dt in DTS[2:6]] + [3e-12, 5e-12]  # pre-asymptotic, then round-off
    fit = observed_order(DTS, errors, floor=1e-12)
    # above the ceiling (0.1): the first two; the error rose after its smallest (3e-12 at DTS[6]): the last one,
    # and every error within ROUNDOFF_BAND (10x) of that smallest: 3e-12 itself and 6e-12 (DTS[5]), just above it
    assert fit.used == DTS[2:5]
    # local orders 4, 4: the pairs into round-off (4 then 0.99) are gone
    assert fit.order == pytest.approx(4, abs=1e-12) and fit.local_orders == pytest.approx([4, 4], abs=1e-12)


def test_errors_bent_by_a_methods_own_round_off_are_dropped():
    """EXUDYN's RK44 on the satellite model (20 s): 1.39e-9, 8.65e-11, 1.06e-11, 2.11e-12, then 9.78e-12: its round-off
    floor (~1e-11) is above the study's, and the errors within 10x of its smallest are bent by it (local orders 4.00,
    3.03, 2.32). Above them, 4.00. Where the error keeps falling to the finest step, nothing more is dropped (an
    order-2 defect keeps its evidence)."""
    dts = [1 / 128, 1 / 256, 1 / 512, 1 / 1024, 1 / 2048]
    fit = observed_order(dts, [1.386e-09, 8.646e-11, 1.057e-11, 2.112e-12, 9.783e-12], floor=2.2e-13)
    assert fit.used == dts[:2] and fit.order == pytest.approx(4.00, abs=0.01)
    defect = [1e-3 * dt**2 for dt in dts]
    fit = observed_order(dts, defect, floor=1e-15)
    assert fit.used == dts and fit.order == pytest.approx(2, abs=1e-12)


def test_no_order_without_two_points():
    assert observed_order(DTS[:2], [1e-14, 1e-15]).order is None  # below the floor
    assert observed_order(DTS[:2], [None, None]).note.startswith("no run completed")


def test_median_ignores_one_odd_pair():
    errors = [1e-3 * dt**4 for dt in DTS]
    errors[-2] *= 3.0  # one odd point moves two local orders; the median of the last three keeps 4 within 1.6
    fit = observed_order(DTS, errors, floor=1e-30)
    assert abs(fit.order - 4) < abs(np.log2(3)) + 1e-9


def test_errors_against_itself_are_zero():
    t = np.linspace(0, 1, 5)
    q = np.tile([1.0, 0, 0, 0], (5, 1))
    w = np.tile([0.1, 0.2, 0.3], (5, 1))
    err = errors_against(Trajectory(t=t, q=q, omega=w), q, w)
    assert err == {"attitude_error": 0.0, "max_attitude_error": 0.0, "omega_error": 0.0, "max_omega_error": 0.0}
    # a rotation of 1e-3 rad about z: the attitude error is that angle
    q2 = np.tile([np.cos(5e-4), 0, 0, np.sin(5e-4)], (5, 1))
    assert errors_against(Trajectory(t=t, q=q2, omega=w), q, w)["attitude_error"] == pytest.approx(1e-3, rel=1e-12)


def test_steady_spin_invariants_are_exact():
    """Truth: spin about a principal axis is steady; E = 1/2 I w^2, |H| = I w, and nothing drifts."""
    I = np.diag([1.0, 2.0, 3.0])
    t = np.linspace(0, 1, 11)
    ang = 0.5 * 2.0 * t  # w = 2 rad/s about z
    q = np.stack([np.cos(ang), 0 * t, 0 * t, np.sin(ang)], axis=1)
    w = np.tile([0.0, 0.0, 2.0], (11, 1))
    assert kinetic_energy(I, w[0]) == pytest.approx(6.0)
    np.testing.assert_allclose(world_momentum(I, q, w), np.tile([0, 0, 6.0], (11, 1)), atol=1e-15)
    drift = invariant_changes(I, Trajectory(t=t, q=q, omega=w))
    assert drift["energy_change"] == 0 and abs(drift["momentum_change"]) < 1e-15 and drift["momentum_turn"] < 1e-15
    assert drift["norm_drift"] < 1e-15


# ------------------------------------------------------------------------------------------------
# the largest step within a tolerance (issue 10)
# ------------------------------------------------------------------------------------------------
from xcheck.metrics import TOLERANCES, largest_step_within, tolerance_key  # noqa: E402

STEP_DTS = [0.1 / 2**k for k in range(6)]


def power_law(p=4, c=1e-2):
    """e = c (dt / 0.1)^p, wall = 1e-3 (0.1 / dt): on the log-log line exactly."""
    return [c * (dt / 0.1) ** p for dt in STEP_DTS], [1e-3 * 0.1 / dt for dt in STEP_DTS]


def test_step_within_is_exact_on_a_power_law():
    """Truth: e = 1e-2 (dt/0.1)^4 = 1e-6 at dt = 0.1 * 1e-4^(1/4) = 0.01 s, where the wall time is 1e-2 s."""
    errors, walls = power_law()
    w = largest_step_within(STEP_DTS, errors, walls, 1e-6)
    assert w.how == "interpolated"
    assert w.dt == pytest.approx(0.01, rel=1e-12) and w.wall_time == pytest.approx(1e-2, rel=1e-12)
    assert [tolerance_key(t) for t in TOLERANCES] == ["1e-03", "1e-06", "1e-09"]


def test_step_within_at_the_ends():
    errors, walls = power_law()
    coarse = largest_step_within(STEP_DTS, errors, walls, 1.0)  # every step within: the coarsest, no extrapolation
    assert (coarse.dt, coarse.wall_time, coarse.how) == (0.1, pytest.approx(1e-3), "tested")
    none = largest_step_within(STEP_DTS, errors, walls, 1e-20)  # not even the finest
    assert (none.dt, none.wall_time, none.how) == (None, None, "none")


def test_a_failed_or_erratic_step_bounds_the_range():
    """A failed run (None) counts as outside; a coarser step that happens to be within again does not count."""
    errors, walls = power_law()
    errors[2] = None  # dt = 0.025 failed
    w = largest_step_within(STEP_DTS, errors, walls, 1e-3)
    assert (w.dt, w.how) == (STEP_DTS[3], "tested")  # 0.0125: the last within before the failure
    errors, walls = power_law()
    errors[4] = 1.0  # an outlier at dt = 0.00625: the steps above it are not trusted
    w = largest_step_within(STEP_DTS, errors, walls, 1e-6)
    assert w.how == "interpolated" and STEP_DTS[5] < w.dt < STEP_DTS[4]


def _numpy_errors(traj, q_ref, omega_ref):
    """The errors as numpy states them: rotations.attitude_error and a norm over the rows (the truth the compiled
    pass must equal bit for bit)."""
    from xcheck import rotations as rot

    att = rot.attitude_error(traj.q, q_ref)
    om = np.linalg.norm(traj.omega - omega_ref, axis=-1)
    return {"attitude_error": float(att[-1]), "max_attitude_error": float(att.max()),
            "omega_error": float(om[-1]), "max_omega_error": float(om.max())}


def _numpy_changes(inertia, traj):
    """The invariants' largest signed changes in numpy, each sum written out in one order (a BLAS dot may fuse)."""
    from xcheck.metrics import kinetic_energy, world_momentum

    E = kinetic_energy(inertia, traj.omega)
    L = world_momentum(inertia, traj.q, traj.omega)
    x, y, z = L.T
    size = np.sqrt(x * x + y * y + z * z)
    x0, y0, z0 = L[0]
    cross = np.sqrt((y * z0 - z * y0) ** 2 + (z * x0 - x * z0) ** 2 + (x * y0 - y * x0) ** 2)
    turn = np.arctan2(cross, x * x0 + y * y0 + z * z0)

    def largest(a):
        return float(a[np.argmax(np.abs(a))])

    return {"energy_change": largest((E - E[0]) / E[0]), "momentum_change": largest(size / size[0] - 1.0),
            "momentum_turn": float(turn.max()),
            "norm_drift": float(np.max(np.abs(np.linalg.norm(traj.q, axis=-1) - 1.0)))}


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "numpy"])
@pytest.mark.parametrize("seed", range(4))
def test_the_compiled_metrics_are_numpys_bit_for_bit(seed, compiled, monkeypatch):
    """Random trajectories (quaternions of any length, a rotated inertia tensor) against their numpy statement,
    both ways the metrics are computed: the compiled pass, and numpy's calls that a process without our compiled
    code loaded takes (a worker that drives Basilisk alone)."""
    from xcheck import metrics
    from xcheck import rotations as rot
    from xcheck.metrics import errors_against, invariant_changes

    monkeypatch.setattr(metrics, "compiled_code_loaded", lambda: compiled)

    rng = np.random.default_rng(seed)
    n = 1000 + 37 * seed
    q = rng.normal(size=(n, 4)) * rng.uniform(0.5, 2.0, size=(n, 1))
    q_ref = q + rng.normal(scale=10.0 ** -rng.uniform(3, 14, size=(n, 1)), size=(n, 4))
    w, w_ref = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    R = rot.quat_to_dcm(rot.quat_normalize(rng.normal(size=4)))
    inertia = R @ np.diag([1.0, 2.0, 2.5]) @ R.T
    traj = Trajectory(t=np.arange(n) * 0.01, q=q, omega=w)
    assert errors_against(traj, q_ref, w_ref) == _numpy_errors(traj, q_ref, w_ref)
    assert invariant_changes(inertia, traj) == _numpy_changes(inertia, traj)


def test_a_nan_in_a_run_is_its_largest_error_as_with_numpy():
    from xcheck.metrics import errors_against

    q = np.tile([1.0, 0.0, 0.0, 0.0], (5, 1))
    w = np.zeros((5, 3))
    bad = w.copy()
    bad[2, 1] = np.nan
    out = errors_against(Trajectory(t=np.arange(5.0), q=q, omega=bad), q, w)
    assert np.isnan(out["max_omega_error"]) and out["omega_error"] == 0.0 and out["max_attitude_error"] == 0.0
    with pytest.raises(ValueError, match="as many"):
        errors_against(Trajectory(t=np.arange(5.0), q=q, omega=w), q[:4], w[:4])


def test_round_off_noise_that_dips_at_the_finest_step_is_still_round_off():
    """EXUDYN's trapezoidal rule on the near-singular gyroscope: second order down to ~2e-12, then round-off noise
    whose last value (1.58e-12) happens to be the smallest: a rise below 1e-8 marks round-off, and the errors within 10x
    of the smallest go; the order is the 2.00 above them (it was -1.24)."""
    dts = [2.0**-k for k in range(1, 13)]
    errors = [7.60e-08, 1.02e-08, 2.03e-09, 4.95e-10, 1.23e-10, 3.08e-11, 7.68e-12, 1.92e-12, 1.75e-12, 4.15e-12,
              2.23e-11, 1.58e-12]
    fit = observed_order(dts, errors, floor=2.6e-14)
    assert fit.order == pytest.approx(2.0, abs=0.02) and fit.used == dts[:6]


def test_a_pre_asymptotic_wiggle_far_above_the_floor_is_not_round_off():
    """MuJoCo's RK4 on the near-singular gyroscope: 2.43e-9 then 3.31e-9 at the two coarsest steps (a wiggle below 1e-8
    but 1e5 above its lowest, 1.03e-14), then fourth order: the wiggle is kept as before (order 4.07), only the rise
    from its lowest is round-off."""
    dts = [2.0**-k for k in range(1, 13)]
    errors = [2.43e-09, 3.31e-09, 1.75e-10, 1.04e-11, 6.46e-13, 6.17e-14, 4.17e-14, 1.03e-14, 1.57e-13, 6.70e-13,
              2.75e-12, 2.30e-11]
    fit = observed_order(dts, errors, floor=1e-12)
    assert fit.used == dts[:4] and fit.order == pytest.approx(4.07, abs=0.01)
