"""The run plan and the initial state: checked in one place (``xcheck.trajectory``), with the same words
whichever runner or reference is given the input."""

import numpy as np
import pytest

from xcheck.engines.mujoco import simulate
from xcheck.integrators import integrate, integrate_batch
from xcheck.paths import BUNDLED_MODELS
from xcheck.reference import dop853_solution, exact_torque_free
from xcheck.trajectory import check_initial_state, step_plan, time_grid

I = [0.005625, 0.0028125, 0.0028125]
Q0, W0 = [1.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3]


def test_initial_state_is_normalised_without_overflow():
    """Truth: q / |q| computed by hand; a quaternion of 1e300 components does not overflow."""
    q, w = check_initial_state([2.0, 0.0, 0.0, 0.0], W0)
    np.testing.assert_array_equal(q, [1.0, 0, 0, 0])
    np.testing.assert_array_equal(w, W0)
    q, _ = check_initial_state([1e300, 1e300, 0.0, 0.0], W0)
    np.testing.assert_allclose(q, [2**-0.5, 2**-0.5, 0, 0], rtol=1e-15)
    q, w = check_initial_state([[0.0, 3.0, 0, 4.0]] * 2, [W0] * 2, batch=True)
    np.testing.assert_allclose(q, [[0, 0.6, 0, 0.8]] * 2, rtol=1e-15)


@pytest.mark.parametrize("q0, omega0, match", [
    ([0.0, 0, 0, 0], W0, "q0: a zero quaternion"),
    ([np.nan, 0, 0, 1], W0, "q0: contains non-finite"),
    ([1.0, 0, 0], W0, r"q0: expected shape \(4,\)"),
    ("north", W0, "q0: expected 4 numbers"),
    (Q0, [0.1, 0.2], r"omega0: expected shape \(3,\)"),
    (Q0, [0.1, np.inf, 0.0], "omega0: contains non-finite"),
])
def test_every_runner_and_reference_says_the_same(q0, omega0, match):
    calls = [
        lambda: integrate("lie-rkmk4", I, q0, omega0, dt=0.1, duration=1.0),
        lambda: simulate(BUNDLED_MODELS / "gyroscope.xml", integrator="rk4", q0=q0, omega0=omega0, dt=0.1,
                         duration=1.0),
        lambda: exact_torque_free(I, q0, omega0, np.array([0.0, 1.0])),
        lambda: dop853_solution(I, q0, omega0, 1.0),
    ]
    for call in calls:
        with pytest.raises(ValueError, match=match):
            call()


def test_batch_shapes_are_checked_together():
    with pytest.raises(ValueError, match=r"q0: expected shape \(N, 4\)"):
        integrate_batch("lie-rkmk4", I, Q0, W0, dt=0.1, duration=1.0)
    with pytest.raises(ValueError, match="as many attitudes as body rates, got 2 and 3"):
        check_initial_state([Q0] * 2, [W0] * 3, batch=True)


def test_step_plan_lands_on_the_duration():
    """Truth: 10 s at 0.3 s is 33 steps of 0.3 s and a last one of 0.1 s; 1 s at 1/1024 s is 1024 equal steps."""
    n, last = step_plan(0.3, 10.0)
    assert n == 34 and last == pytest.approx(0.1, abs=1e-12)
    assert step_plan(1 / 1024, 1.0) == (1024, pytest.approx(1 / 1024, rel=1e-12))
    t = time_grid(n, 0.3, 10.0)
    assert t[-1] == 10.0 and t[1] == 0.3 and len(t) == 35
