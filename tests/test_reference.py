"""The exact torque-free solution against an independent library (scipy's DOP853 at rtol 1e-13) and
against its own differential equations (finite differences), for every kind of inertia."""

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.metrics import kinetic_energy, world_momentum
from xcheck.reference import dop853, dop853_solution, elliptic_period, exact_torque_free

T = np.linspace(0.0, 10.0, 401)
Q0 = rot.quat_normalize([0.8, 0.1, -0.4, 0.3])

CASES = {
    # name: (inertia, omega0)
    "tumbling near the intermediate axis": ([1.0, 2.0, 3.0], [0.02, 1.0, 0.03]),
    "circulating about the largest axis": ([1.0, 2.0, 3.0], [0.3, -0.5, 1.2]),
    "circulating about the smallest axis": ([1.0, 2.0, 3.0], [1.0, 0.1, -0.05]),
    "unordered moments": ([0.03, 0.01, 0.02], [0.5, 1.5, -0.7]),
    "gyroscope of seed 001 (axisymmetric, flat plate)": ([0.005625, 0.0028125, 0.0028125], [-0.00518, 0.02, 15.71]),
    "prolate axisymmetric": ([1.0, 1.0, 0.4], [0.3, 0.2, 2.0]),
    "RAX-1 (seed 004 eq. 176)": ([0.018, 0.018, 0.006], np.radians([1.5, -1.0, 0.5])),
    "spherical": ([2.0, 2.0, 2.0], [0.3, -0.2, 0.5]),
    "steady spin about the intermediate axis": ([1.0, 2.0, 3.0], [0.0, 0.7, 0.0]),
    "flat plate asymmetric (I3 = I1 + I2)": ([1.0, 2.0, 3.0], [0.4, 0.6, 0.9]),
}


@pytest.mark.parametrize("name", CASES)
def test_exact_agrees_with_dop853(name):
    inertia, w0 = CASES[name]
    q, w = exact_torque_free(inertia, Q0, w0, T)
    q_ref, w_ref = dop853(inertia, Q0, w0, T)
    assert rot.attitude_error(q, q_ref).max() < 1e-9
    np.testing.assert_allclose(w, w_ref, atol=1e-9 * max(1.0, np.linalg.norm(w0)))
    np.testing.assert_allclose(q[0], Q0, atol=1e-15)
    np.testing.assert_allclose(w[0], w0, atol=1e-14)


def test_exact_for_a_rotated_inertia_tensor():
    """A full tensor (principal axes not the body axes) is rotated to principal axes and back."""
    R = rot.quat_to_dcm(rot.quat_normalize([0.9, 0.3, -0.2, 0.25]))
    tensor = R @ np.diag([1.0, 2.0, 3.0]) @ R.T
    w0 = np.array([0.4, 0.9, -0.3])
    q, w = exact_torque_free(tensor, Q0, w0, T)
    q_ref, w_ref = dop853(tensor, Q0, w0, T)
    assert rot.attitude_error(q, q_ref).max() < 1e-9
    np.testing.assert_allclose(w, w_ref, atol=1e-9)


@pytest.mark.parametrize("name", ["tumbling near the intermediate axis", "circulating about the smallest axis",
                                  "gyroscope of seed 001 (axisymmetric, flat plate)"])
def test_exact_solves_its_equations_and_keeps_its_invariants(name):
    """Euler's equations and q' = 1/2 q ⊗ (0, w) by central differences; energy and world angular
    momentum constant to round-off."""
    inertia, w0 = CASES[name]
    I = np.diag(inertia)
    t = np.array([0.0, 1.3, 4.7, 9.1])
    h = 1e-5
    q, w = exact_torque_free(inertia, Q0, w0, t)
    qp, wp = exact_torque_free(inertia, Q0, w0, t + h)
    qm, wm = exact_torque_free(inertia, Q0, w0, t - h)
    wdot = (wp - wm) / (2 * h)
    euler = -np.cross(w, w @ I.T) @ np.linalg.inv(I).T
    scale = max(1.0, np.linalg.norm(w0) ** 2)
    np.testing.assert_allclose(wdot, euler, atol=1e-7 * scale)
    qdot = (qp - qm) / (2 * h)
    np.testing.assert_allclose(qdot, rot.quat_rate(q, w), atol=1e-7 * scale)
    qq, ww = exact_torque_free(inertia, Q0, w0, T)
    E = kinetic_energy(inertia, ww)
    H = world_momentum(inertia, qq, ww)
    assert np.abs(E / E[0] - 1).max() < 1e-13
    assert np.abs(H - H[0]).max() / np.linalg.norm(H[0]) < 1e-13


def test_exact_at_unsorted_and_negative_times():
    inertia, w0 = CASES["tumbling near the intermediate axis"]
    t = np.array([3.0, -2.0, 0.5, 3.0])
    q, w = exact_torque_free(inertia, Q0, w0, t)
    q_sorted, w_sorted = exact_torque_free(inertia, Q0, w0, np.array([-2.0, 0.5, 3.0]))
    assert rot.attitude_error(q[[1, 2, 0]], q_sorted).max() < 1e-14
    np.testing.assert_allclose(w[3], w[0], atol=0)


def test_elliptic_period():
    inertia, w0 = CASES["circulating about the largest axis"]
    period = elliptic_period(inertia, w0)
    _, w = exact_torque_free(inertia, Q0, w0, np.array([0.0, period]))
    np.testing.assert_allclose(w[1], w[0], atol=1e-12)


def test_dop853_rejects_descending_times():
    with pytest.raises(ValueError, match="t: expected ascending times from 0"):
        dop853([1.0, 2.0, 3.0], Q0, [0.1, 0.2, 0.3], [1.0, 0.5])


def test_dop853_restarts_at_a_field_tables_rows():
    """Truth: lie-rkmk4 at 1/4096 s, whose steps fall on the table's rows (every 1/2 s), so that its order-4 error
    is 2.6e-14 rad (its difference from 1/2048 s). The body-frame field table is linear between its rows, its
    derivative jumps at them: DOP853 restarted there agrees with it to 1e-13 rad; stepping across them it was
    1.6e-12 rad and 3e-12 rad/s off (its error estimate is no estimate across a kink)."""
    from xcheck.runners import RUNNERS
    from xcheck.scenario import resolve_scenario
    from xcheck.study.context import run_context

    sc = resolve_scenario("rax1-body-field")
    ctx = run_context(sc)
    breaks = ctx.torque.breakpoints(ctx.duration)
    assert np.array_equal(breaks, np.arange(0.5, 10.0, 0.5))
    fine = RUNNERS["lie-rkmk4"].run(ctx, 1 / 4096)
    q, w = dop853_solution(ctx.inertia, ctx.q0, ctx.omega0, ctx.duration, torque=ctx.torque)(fine.t)
    assert rot.attitude_error(q, fine.q).max() < 1e-13 and np.abs(w - fine.omega).max() < 1e-14
    from xcheck.fields.models import ConstantTorque

    assert len(ctx.torque.breakpoints(0.5)) == 0 and len(ConstantTorque([0.0, 0.0, 1e-4]).breakpoints(5.0)) == 0
