"""Our integrators against the exact torque-free solution and against each other.

Truths: the exact solution (xcheck.reference.exact_torque_free, itself checked against DOP853 in
test_reference.py); the order conditions of the tableau (exact fractions); the linear solve of seed 004
eq. 154. Tolerances are stated next to each assertion.
"""

from fractions import Fraction

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.fields import BodyFieldTable, ConstantTorque, MagneticTorque, UniformField
from xcheck.integrators import METHODS, integrate, integrate_batch
from xcheck.integrators.tableau import KUTTA3, RK4, RK38, THESIS_172_DEXP_A
from xcheck.metrics import invariant_changes, observed_order
from xcheck.reference import exact_torque_free

# seed 001: m = 2 kg, d = 0.15 m, I = [1/2 m r^2, 1/4 m r^2, 1/4 m r^2], x the symmetry axis
GYRO_I = np.array([0.005625, 0.0028125, 0.0028125])
RATES = np.array([0.02, 0.02, 15.71])  # [psi', theta', phi'] rad/s
DURATION = 10.0
FIXED_STEP = [name for name, m in METHODS.items() if m.kernel is not None]
RK4_METHODS = [name for name, m in METHODS.items() if m.expected_order == 4 and not m.exact_torque_free]
#: the splittings: torque free, their step is the exact flow (no order; tests/test_split.py)
EXACT_FREE = [name for name, m in METHODS.items() if m.exact_torque_free]


def gyro_initial(theta_deg):
    ang = np.radians([0.0, theta_deg, 0.0])
    return rot.euler_to_quat(ang, "323"), rot.euler_rates_to_omega(ang, RATES, "323")


def final_error(method, inertia, q0, w0, dt, duration=DURATION, **kw):
    traj = integrate(method, inertia, q0, w0, dt=dt, duration=duration, **kw)
    q_ref, w_ref = exact_torque_free(inertia, q0, w0, traj.t[-1:])
    return traj, rot.attitude_error(traj.q[-1], q_ref[-1])


# ------------------------------------------------------------------------------------------------
# the tableau
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("tableau", [RK4, RK38, KUTTA3])
def test_tableau_consistency_and_order_conditions(tableau):
    A = [[Fraction(x) for x in row] for row in tableau.A]
    b = [Fraction(x) for x in tableau.b]
    c = [Fraction(x) for x in tableau.c]
    s = len(b)
    assert sum(b) == 1
    assert all(sum(A[i]) == c[i] for i in range(s))
    assert all(A[i][j] == 0 for i in range(s) for j in range(i, s))  # explicit
    Ac = [sum(A[i][j] * c[j] for j in range(s)) for i in range(s)]
    # the eight conditions of order 4 (Butcher), of which the first four are those of order 3
    conditions = [
        (sum(b[i] * c[i] for i in range(s)), Fraction(1, 2)),
        (sum(b[i] * c[i] ** 2 for i in range(s)), Fraction(1, 3)),
        (sum(b[i] * Ac[i] for i in range(s)), Fraction(1, 6)),
        (sum(b[i] * c[i] ** 3 for i in range(s)), Fraction(1, 4)),
        (sum(b[i] * c[i] * Ac[i] for i in range(s)), Fraction(1, 8)),
        (sum(b[i] * A[i][j] * c[j] ** 2 for i in range(s) for j in range(s)), Fraction(1, 12)),
        (sum(b[i] * A[i][j] * Ac[j] for i in range(s) for j in range(s)), Fraction(1, 24)),
    ]
    held = [got == want for got, want in conditions]
    assert all(held[:3])  # order 3: the first three with sum(b) = 1
    assert all(held) == (tableau.order == 4) and tableau.order in (3, 4)


@pytest.mark.parametrize("scheme, tableau", [("formulation-2", KUTTA3), ("lie-rkmk4", RK38), ("dcm-rk4", RK38)])
def test_a_tableau_the_kernels_were_never_written_for_runs_at_its_order(scheme, tableau):
    """Issue 38: the stage loop is generated from a tableau's exact fractions (it hard-coded the classical RK4, and
    a method on any other tableau was refused). Kutta's third-order method and the 3/8 rule on schemes of the
    registry, made by hand: truth, the exact torque-free solution of an asymmetric body over 10 s; their observed
    orders within 0.15 of the tableau's; the 3/8 rule's error within a factor 2 of the classical RK4's (the same
    order, a different error constant), and never equal to it (another method, not the same code)."""
    from xcheck.integrators import Method

    base = METHODS[scheme]
    method = Method(f"{scheme} ({tableau.name})", base.kernel, tableau.order, "made by a test", "test",
                    tableau=tableau)
    I, q0, w0 = np.array([1.0, 2.0, 3.0]), rot.quat_normalize(np.array([0.9, 0.1, 0.3, 0.2])), np.array([0.3, 1.2, -0.7])
    steps = [1 / 32, 1 / 64, 1 / 128, 1 / 256]
    errors = [final_error(method, I, q0, w0, dt)[1] for dt in steps]
    orders = [np.log2(errors[k] / errors[k + 1]) for k in range(len(steps) - 1)]
    assert abs(orders[-1] - tableau.order) < 0.15, orders
    if tableau.order == 4:
        classical = final_error(scheme, I, q0, w0, steps[-1])[1]
        assert classical / 2 < errors[-1] < 2 * classical and errors[-1] != classical


def test_an_implicit_tableau_is_refused_when_the_method_is_made():
    from xcheck.integrators import Method
    from xcheck.integrators.tableau import ButcherTableau

    implicit = ButcherTableau("implicit midpoint", ((Fraction(1, 2),),), (Fraction(1),), (Fraction(1, 2),), 2)
    with pytest.raises(ValueError, match="implicit midpoint: an implicit tableau"):
        Method("formulation-2 (implicit midpoint)", METHODS["formulation-2"].kernel, 2, "", "", tableau=implicit)


def test_thesis_172_differs_from_rk4_only_in_the_third_stage():
    diff = [(i, j) for i in range(4) for j in range(4) if THESIS_172_DEXP_A[i][j] != RK4.A[i][j]]
    assert diff == [(2, 0), (2, 1)]


# ------------------------------------------------------------------------------------------------
# torque-free gyroscope, seed 001 (theta0 = 15 deg), against the exact solution
# ------------------------------------------------------------------------------------------------
STEPS = [2.0**-k for k in range(4, 13)]  # 1/16 ... 1/4096 s


@pytest.fixture(scope="module")
def gyro_sweep():
    q0, w0 = gyro_initial(15.0)
    return {m: [final_error(m, GYRO_I, q0, w0, dt)[1] for dt in STEPS] for m in METHODS}


@pytest.mark.parametrize("method", RK4_METHODS)
def test_every_rk4_method_reaches_order_4_on_the_gyroscope(gyro_sweep, method):
    fit = observed_order(STEPS, gyro_sweep[method])
    assert fit.order is not None, fit.note
    assert abs(fit.order - 4) < 0.3, (fit.order, gyro_sweep[method])


@pytest.mark.parametrize("method", EXACT_FREE)
def test_the_splittings_are_the_gyroscopes_exact_flow_at_every_step(gyro_sweep, method):
    """Truth: the closed form. Torque free a splitting is the exact flow: within 5e-12 rad at every step from 1/16 to
    1/4096 s, where RK4 at 1/16 s is 3e-4 off. What is left is round-off's random walk in the invariants over up to
    123 000 flows (the triple jump's; 9e-13 measured for Strang's 41 000, 1.8e-12 for them), not a drift: each flow
    adds its increments, rounded relative to what they change (as m(h) itself, the gyroscope was 1.5e-10 off)."""
    assert max(gyro_sweep[method]) < 5e-12, gyro_sweep[method]


def test_printed_algorithm_172_has_order_2(gyro_sweep):
    """Seed 004 algorithm 172 as printed (1/2 k1 in the third stage's dexp^-1) is only second order:
    the finding that made the corrected RKMK4 the default ``lie-rkmk4``."""
    fit = observed_order(STEPS, gyro_sweep["lie-thesis-172"])
    assert abs(fit.order - 2) < 0.2, fit
    assert METHODS["lie-thesis-172"].expected_order == 2


def test_lie_rkmk4_is_in_mujoco_league_at_1_256(gyro_sweep):
    """Issue 3: below 1e-10 rad at dt = 1/256 s after 10 s (MuJoCo 4.0 RK4 reaches 2.3e-12 there)."""
    err = gyro_sweep["lie-rkmk4"][STEPS.index(1 / 256)]
    assert err < 1e-10


def test_scipy_rk45_at_default_tolerances_is_the_seed_script_accuracy(gyro_sweep):
    """solve_ivp RK45 at rtol 1e-3 does not converge with the output grid: its error is set by its
    tolerance (about 0.07 rad after 10 s here), the same for every dt."""
    errs = np.array(gyro_sweep["scipy-rk45"])
    assert np.all((errs > 1e-2) & (errs < 0.2))
    assert np.ptp(errs) < 1e-6


@pytest.mark.parametrize("method", FIXED_STEP)
def test_invariants_hold_on_the_gyroscope(method):
    q0, w0 = gyro_initial(15.0)
    traj = integrate(method, GYRO_I, q0, w0, dt=1 / 512, duration=DURATION)
    drift = invariant_changes(GYRO_I, traj)
    # normalised each step, or unit by construction (Lie: a product of unit quaternions, whose rounding
    # drifts by about eps per step: 2.7e-13 after these 5120 steps)
    assert drift["norm_drift"] < (len(traj.t) - 1) * np.finfo(float).eps
    assert abs(drift["energy_change"]) < 1e-7 and abs(drift["momentum_change"]) < 1e-7 and drift["momentum_turn"] < 1e-7
    if method == "dcm-rk4":
        assert drift["orthogonality_drift"] < 1e-14  # Björck-Bowie after every step


# ------------------------------------------------------------------------------------------------
# seed 001's near-singular and singular initial conditions
# ------------------------------------------------------------------------------------------------
def test_near_singular_euler_angles_stall_while_quaternions_converge():
    """theta0 = 0.001 deg: the Euler-angle solution does not converge (its error stays ~3e-4 rad as dt
    shrinks 16-fold), the quaternion methods do."""
    q0, w0 = gyro_initial(0.001)
    euler = [final_error("euler-rk4", GYRO_I, q0, w0, dt)[1] for dt in (1 / 64, 1 / 1024)]
    assert euler[1] > 1e-4 and euler[1] > 0.3 * euler[0]
    for method in ("formulation-1", "formulation-2", "lie-rkmk4", "dcm-rk4", "rotvec-rk4"):
        traj, err = final_error(method, GYRO_I, q0, w0, 1 / 1024)
        assert traj.ok and err < 1e-7, (method, err)


def test_singular_start_is_reported_and_quaternions_run():
    q0, w0 = gyro_initial(0.0)
    traj = integrate("euler-rk4", GYRO_I, q0, w0, dt=1 / 64, duration=DURATION)
    assert traj.status == "singular"
    assert len(traj.t) == 1 and np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.omega))
    assert "t = 0 s" in traj.message and "middle angle 0 rad" in traj.message
    for method in FIXED_STEP:
        if method == "euler-rk4":
            continue
        traj, err = final_error(method, GYRO_I, q0, w0, 1 / 256)
        # each at its own accuracy (dcm-rk4: 1.9e-5; the second-order variational integrator's phase error on the
        # 15.7 rad/s spin: 0.099)
        assert traj.ok and err < (0.12 if method == "lie-lgvi" else 1e-4), (method, err)


def test_euler_rk4_runs_every_sequence():
    """Any of the 12 sequences: the gyroscope from a generic attitude converges to the same answer."""
    q0 = rot.quat_normalize([0.9, 0.2, -0.3, 0.25])
    w0 = np.array([0.4, -0.3, 2.0])
    for seq in rot.EULER_SEQUENCES:
        traj, err = final_error("euler-rk4", GYRO_I, q0, w0, 1 / 256, duration=2.0, sequence=seq)
        if traj.ok:
            assert err < 1e-7, (seq, err)
        else:  # the motion may cross a sequence's singularity: then it says so
            assert traj.status == "singular" and seq in traj.message


# ------------------------------------------------------------------------------------------------
# an asymmetric tumbling body near its intermediate axis
# ------------------------------------------------------------------------------------------------
TUMBLE_I = np.array([1.0, 2.0, 3.0])
TUMBLE_Q0 = rot.quat_normalize([0.8, 0.1, -0.4, 0.3])
TUMBLE_W0 = np.array([0.02, 1.0, 0.03])


@pytest.mark.parametrize("method", ["formulation-1", "formulation-2", "lie-rkmk4", "dcm-rk4", "gibbs-rk4",
                                    "rotvec-rk4"])
def test_quaternion_methods_reach_order_4_on_a_tumbling_body(method):
    steps = [2.0**-k for k in range(3, 9)]
    errs = [final_error(method, TUMBLE_I, TUMBLE_Q0, TUMBLE_W0, dt)[1] for dt in steps]
    fit = observed_order(steps, errs)
    assert fit.order is not None and abs(fit.order - 4) < 0.3, (fit, errs)


# ------------------------------------------------------------------------------------------------
# RAX-1 (seed 004 §3): attitude-independent and attitude-dependent magnetic torque
# ------------------------------------------------------------------------------------------------
RAX_I = np.array([0.018, 0.018, 0.006])  # eq. 176
RAX_DIPOLE = np.array([0.14, 0.02, 1.09])  # eq. 175
RAX_P0 = rot.quat_normalize([-0.4583, -0.6558, 0.5997, 0.0182])  # eq. 178
RAX_W0 = np.radians([1.5, -1.0, 0.5])  # 1-2 deg/s about xi and eta (the thesis's Fig. 11)


def rax_table():
    t = np.arange(0.0, 20.5, 0.5)
    H = np.stack([20 + 5 * np.sin(t / 7), -10 + 8 * np.cos(t / 5), 15 + 3 * np.sin(t / 3)], axis=1)  # [A/m]
    return np.column_stack([t, H])


def test_rax1_formulation2_and_lie_agree_when_the_torque_ignores_attitude():
    """The thesis's finding (§3.3): with a body-frame field table both methods integrate the very same
    body rates (the torque sees only t), and their attitudes agree to ~1e-10 rad at dt = 0.5 s and to
    round-off below dt = 1/8 s."""
    torque = MagneticTorque(RAX_DIPOLE, BodyFieldTable(rax_table()))
    for dt, tol in [(0.5, 1e-9), (1 / 8, 1e-11), (1 / 64, 1e-12)]:
        f2 = integrate("formulation-2", RAX_I, RAX_P0, RAX_W0, dt=dt, duration=DURATION, torque=torque)
        lie = integrate("lie-rkmk4", RAX_I, RAX_P0, RAX_W0, dt=dt, duration=DURATION, torque=torque)
        np.testing.assert_array_equal(f2.omega, lie.omega)
        assert rot.attitude_error(f2.q[-1], lie.q[-1]) < tol


def test_rax1_attitude_dependent_torque_separates_the_body_rates():
    """With a field fixed in inertial space the torque depends on attitude, and the two methods' rates
    part: measured 3.9e-12 rad/s at dt = 0.5 s (zero with the body-frame table), shrinking as dt^4."""
    torque = MagneticTorque(RAX_DIPOLE, UniformField([20.0, -10.0, 15.0]))
    diffs = []
    for dt in (0.5, 0.25):
        f2 = integrate("formulation-2", RAX_I, RAX_P0, RAX_W0, dt=dt, duration=DURATION, torque=torque)
        lie = integrate("lie-rkmk4", RAX_I, RAX_P0, RAX_W0, dt=dt, duration=DURATION, torque=torque)
        diffs.append(np.abs(f2.omega[-1] - lie.omega[-1]).max())
    assert 1e-13 < diffs[0] < 1e-10
    assert 8 < diffs[0] / diffs[1] < 32  # ~16: a fourth-order difference


# ------------------------------------------------------------------------------------------------
# paths: compiled vs interpreted (Python torque), single vs batch, the last step
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("method", FIXED_STEP)
def test_python_torque_callable_runs_the_same_kernel(method):
    model = ConstantTorque([1e-4, -2e-4, 3e-5])
    q0, w0 = gyro_initial(15.0)
    a = integrate(method, GYRO_I, q0, w0, dt=1 / 64, duration=1.0, torque=model)
    b = integrate(method, GYRO_I, q0, w0, dt=1 / 64, duration=1.0, torque=lambda t, q, w: [1e-4, -2e-4, 3e-5])
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.omega, b.omega)


def test_attitude_dependent_python_torque_matches_the_model():
    model = MagneticTorque(RAX_DIPOLE, UniformField([20.0, -10.0, 15.0]))
    a = integrate("lie-rkmk4", RAX_I, RAX_P0, RAX_W0, dt=0.25, duration=5.0, torque=model)
    b = integrate("lie-rkmk4", RAX_I, RAX_P0, RAX_W0, dt=0.25, duration=5.0,
                  torque=lambda t, q, w: model(t, q, w))
    np.testing.assert_allclose(a.q, b.q, atol=1e-15)


@pytest.mark.parametrize("method", ["lie-rkmk4", "formulation-2", "euler-rk4", "dcm-rk4"])
def test_batch_equals_single_trajectories(method):
    rng = np.random.default_rng(7)
    q0 = rot.quat_normalize(rng.normal(size=(5, 4)))
    w0 = rng.normal(size=(5, 3))
    batch = integrate_batch(method, TUMBLE_I, q0, w0, dt=0.05, duration=2.0, save="all")
    final = integrate_batch(method, TUMBLE_I, q0, w0, dt=0.05, duration=2.0)
    for i in range(5):
        single = integrate(method, TUMBLE_I, q0[i], w0[i], dt=0.05, duration=2.0)
        assert batch.status[i] == single.status
        n = len(single.t)
        assert rot.attitude_error(batch.q[i, :n], single.q).max() < 1e-14
        np.testing.assert_allclose(batch.omega[i, :n], single.omega, atol=1e-14)
        assert rot.attitude_error(final.q[i, -1], single.q[-1]) < 1e-14
    assert final.q.shape == (5, 2, 4) and batch.q.shape == (5, 41, 4)


@pytest.mark.parametrize("method", ["formulation-2", "lie-rkmk4"])
def test_the_lanes_give_every_body_the_single_trajectorys_numbers_bit_for_bit(method):
    """Truth: integrate(), one body at a time. Formulation II and the Lie-group method run a batch in blocks of
    bodies in lockstep (_kernels.LANES): 300 bodies (three blocks, the last one short), random attitudes and
    rates, their own inertia or one shared, with an attitude-dependent and a time-dependent torque, and bodies
    that blow up at a coarse step: every component of every saved state equal, the same status and steps."""
    from xcheck.fields import BodyFieldTable, MagneticTorque, UniformField
    from xcheck.integrators import kernels as _kernels

    rng = np.random.default_rng(3)
    n = 300
    assert n > 2 * _kernels.LANES
    q0 = rot.quat_normalize(rng.normal(size=(n, 4)))
    w0 = rng.normal(0.0, 0.5, (n, 3))
    w0[[5, 200]] = [1e3, 2e3, -1e3]  # these blow up
    own = np.array([np.diag(rng.uniform(0.010, 0.018, 3)) for _ in range(n)])
    table = np.column_stack([np.linspace(0, 3, 7), rng.normal(0, 20, (7, 3))])
    torques = [None, MagneticTorque(RAX_DIPOLE, UniformField([20.0, -10.0, 15.0])),
               MagneticTorque(RAX_DIPOLE, BodyFieldTable(table))]
    for inertia, torque in [(RAX_I, torques[0]), (own, torques[1]), (RAX_I, torques[2])]:
        batch = integrate_batch(method, inertia, q0, w0, dt=0.25, duration=3.0, torque=torque, save="all")
        for i in (0, 5, 127, 128, 200, 299):
            one = integrate(method, inertia if np.ndim(inertia) < 3 else inertia[i], q0[i], w0[i], dt=0.25,
                            duration=3.0, torque=torque)
            k = len(one.t)
            assert batch.status[i] == one.status and batch.steps_done[i] == k - 1
            np.testing.assert_array_equal(batch.q[i, :k], one.q)
            np.testing.assert_array_equal(batch.omega[i, :k], one.omega)
            np.testing.assert_array_equal(batch.q[i, k:], np.repeat(one.q[-1:], len(batch.t) - k, axis=0))
    assert batch.status[5] == "failed" and batch.status[0] == "ok"


def test_non_integer_step_count_ends_exactly_at_duration():
    q0, w0 = gyro_initial(15.0)
    traj = integrate("lie-rkmk4", GYRO_I, q0, w0, dt=0.3, duration=1.0)
    np.testing.assert_allclose(traj.t, [0.0, 0.3, 0.6, 0.9, 1.0], rtol=0, atol=2e-16)  # last step: 0.1 s
    assert traj.t[-1] == 1.0
    errs = [final_error("lie-rkmk4", GYRO_I, q0, w0, dt, duration=1.0)[1] for dt in (0.03, 0.015, 0.0075)]
    assert abs(np.log2(errs[0] / errs[1]) - 4) < 0.3 and abs(np.log2(errs[1] / errs[2]) - 4) < 0.3


def test_dcm_rk4_reports_a_step_too_large_for_bjorck_bowie():
    q0, w0 = gyro_initial(15.0)
    traj = integrate("dcm-rk4", GYRO_I, q0, w0, dt=0.5, duration=DURATION)
    assert traj.status == "failed" and "non-finite" in traj.message
    assert np.all(np.isfinite(traj.q))


def test_formulation1_closed_form_solves_eq154():
    """The closed-form p'' of our kernel equals the 4x4 linear solve of seed 004 eq. 154, also for a
    stage value with |p| != 1 and p^T p' != 0."""
    from xcheck.integrators import _kernels_for

    K = _kernels_for(python=True)
    I = np.array([[0.02, 0.001, 0.0], [0.001, 0.03, -0.002], [0.0, -0.002, 0.025]])
    p = np.array([0.7, -0.2, 0.5, 0.4]) * 1.01
    pd = np.array([0.1, 0.3, -0.2, 0.05])
    tau = np.array([1e-3, -2e-3, 5e-4])
    y = np.concatenate([p, pd])
    dy = np.zeros(8)
    K.schemes.deriv_formulation1(0.0, y, dy, I, np.linalg.inv(I), lambda t, q, w: tau, None, None, np.zeros(K.WORK_SIZE[K.F1]))

    def G(e):
        return np.array([[-e[1], e[0], e[3], -e[2]], [-e[2], -e[3], e[0], e[1]], [-e[3], e[2], -e[1], e[0]]])

    M = np.vstack([2 * I @ G(p), p])
    rhs = np.concatenate([tau - 4 * G(p) @ G(pd).T @ I @ G(p) @ pd, [-pd @ pd]])
    np.testing.assert_allclose(dy[4:], np.linalg.solve(M, rhs), rtol=1e-13)
    np.testing.assert_array_equal(dy[:4], pd)


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------
Q0, W0 = np.array([1.0, 0, 0, 0]), np.array([0.1, 0.2, 0.3])


@pytest.mark.parametrize("kwargs, match", [
    (dict(method="rk5"), "method: unknown 'rk5'; expected one of euler-rk4, formulation-1"),
    (dict(inertia=[1.0, -2.0, 2.0]), "principal moment I2 = -2 kg m\\^2 must be positive"),
    (dict(inertia=[1.0, 0.0, 2.0]), "I2 = 0 kg m\\^2 must be positive"),
    (dict(inertia=[1.0, 1.0, 3.0]), "I3 = 3 exceeds I1 \\+ I2 = 2"),
    (dict(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "not symmetric"),
    (dict(inertia=[1.0, 2.0]), "expected principal moments \\(3,\\) or a tensor"),
    (dict(inertia=[1.0, np.inf, 2.0]), "inertia"),
    (dict(q0=[0.0, 0, 0, 0]), "q0: a zero quaternion"),
    (dict(q0=[np.nan, 0, 0, 1]), "q0: contains non-finite"),
    (dict(omega0=[0.1, 0.2]), "omega0: expected shape \\(3,\\)"),
    (dict(dt=-0.1), "dt: expected a positive finite step"),
    (dict(dt=0.0), "dt: expected a positive finite step"),
    (dict(dt=np.nan), "dt: expected a positive finite step"),
    (dict(duration=-1.0), "duration: expected a positive finite time"),
    (dict(duration=np.inf), "duration: expected a positive finite time"),
    (dict(sequence="xyz"), "seq: expected one of 121"),
    (dict(torque="magnetic"), "torque: expected None, a TorqueModel or a callable"),
])
def test_bad_input_names_the_argument(kwargs, match):
    args = dict(method="lie-rkmk4", inertia=[1.0, 2.0, 2.5], q0=Q0, omega0=W0, dt=0.1, duration=1.0)
    args.update(kwargs)
    method, inertia, q0, omega0 = args.pop("method"), args.pop("inertia"), args.pop("q0"), args.pop("omega0")
    with pytest.raises(ValueError, match=match):
        integrate(method, inertia, q0, omega0, **args)


def test_thin_plate_inertia_is_accepted():
    traj = integrate("lie-rkmk4", [1.0, 1.0, 2.0], Q0, W0, dt=0.1, duration=1.0)  # I1 + I2 = I3
    assert traj.ok


def test_bad_python_torque_output_is_named():
    with pytest.raises(ValueError, match=r"torque: the callable returned shape \(2,\)"):
        integrate("lie-rkmk4", [1.0, 2.0, 2.5], Q0, W0, dt=0.1, duration=1.0, torque=lambda t, q, w: [0.0, 1.0])


def test_field_table_must_cover_the_run():
    torque = MagneticTorque(RAX_DIPOLE, BodyFieldTable(rax_table(), source="rax.csv"))
    with pytest.raises(ValueError, match=r"rax.csv: the field table covers 0 to 20 s; the run needs 0 to 30 s"):
        integrate("lie-rkmk4", RAX_I, RAX_P0, RAX_W0, dt=0.5, duration=30.0, torque=torque)


# ------------------------------------------------------------------------------------------------
# lie-cf4: the commutator-free method of order 4 (issue 9's new method)
# ------------------------------------------------------------------------------------------------
def test_cf4_is_exact_for_constant_body_rates():
    """Truth: a spherical body keeps its body rate, so p(t) = p0 ∘ exp(t w) exactly. Every CF4 stage rate is
    w, its two exponentials are exp(h w / 2) each: exact at any step, to round-off."""
    from xcheck.rotations import quat_mul, rotvec_to_quat

    w0 = np.array([0.3, -1.2, 2.5])
    traj = integrate("lie-cf4", [1.0, 1.0, 1.0], [1, 0, 0, 0], w0, dt=0.5, duration=20.0)
    exact = quat_mul(np.array([1.0, 0, 0, 0]), rotvec_to_quat(traj.t[:, None] * w0))
    assert rot.attitude_error(traj.q, exact).max() < 1e-13
    np.testing.assert_array_equal(traj.omega, np.tile(w0, (len(traj.t), 1)))


def test_cf4_order_4_with_an_attitude_dependent_torque():
    """Seed 004's RAX-1 in the orbit-dipole field (the torque depends on attitude), against DOP853 at
    rtol 1e-13 over 10 s with a 15/-10/5 deg/s tumble: order 4 (within 0.3), and agreement with lie-rkmk4
    at the finest step to 1e-10 rad."""
    from xcheck.fields import MagneticTorque, OrbitDipoleField
    from xcheck.reference import dop853

    torque = MagneticTorque([0.14, 0.02, 1.09], OrbitDipoleField())
    w0 = np.radians([15.0, -10.0, 5.0])
    steps = [1 / 8, 1 / 16, 1 / 32, 1 / 64]
    q_ref, _ = dop853(RAX_I, RAX_P0, w0, [0.0, DURATION], torque=torque)
    errs, finest = [], None
    for dt in steps:
        traj = integrate("lie-cf4", RAX_I, RAX_P0, w0, dt=dt, duration=DURATION, torque=torque)
        errs.append(rot.attitude_error(traj.q[-1], q_ref[-1]))
        finest = traj
    fit = observed_order(steps, errs)
    assert abs(fit.order - 4) < 0.3, (fit, errs)
    lie = integrate("lie-rkmk4", RAX_I, RAX_P0, w0, dt=steps[-1], duration=DURATION, torque=torque)
    assert rot.attitude_error(finest.q[-1], lie.q[-1]) < 1e-10


def test_cf4_keeps_the_unit_norm_by_construction():
    q0, w0 = gyro_initial(15.0)
    traj = integrate("lie-cf4", GYRO_I, q0, w0, dt=1 / 64, duration=DURATION)
    assert np.abs(np.linalg.norm(traj.q, axis=1) - 1).max() < 700 * np.finfo(float).eps  # 640 steps


def test_every_scheme_states_its_layout_and_its_state_round_trips():
    """Truth: each scheme's declaration. Its encoded state has the declared layout's length, the parts are consecutive,
    and decoding gives back the attitude (up to sign) and the body rate to 1e-15; a held part that is not the first
    is refused when the scheme is declared."""
    from xcheck.integrators import kernels as K
    from xcheck.integrators.kernels.registry import Scheme, declare, layout, size_of

    rng = np.random.default_rng(5)
    q0 = rng.normal(size=(6, 4))
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    q0 *= np.sign(q0[:, :1])
    w0 = rng.normal(size=(6, 3))
    for scheme in K.SCHEMES:
        parts = list(scheme.state)
        assert parts[0].start == 0 and all(a.stop == b.start for a, b in zip(parts, parts[1:])), scheme.name
        y0 = scheme.encode(q0, w0, "313")
        assert y0.shape == (6, scheme.size) == (6, size_of(scheme.state)), scheme.name
        assert scheme.first == (4 if scheme.held else 0), scheme.name
        q, w, _ = scheme.decode(y0, "313")
        np.testing.assert_allclose(np.abs(np.sum(q * q0, axis=1)), 1.0, atol=1e-15, err_msg=scheme.name)
        np.testing.assert_allclose(w, w0, atol=1e-15, err_msg=scheme.name)
    assert layout(p=4, u=3, w=3).w == slice(7, 10)
    with pytest.raises(ValueError, match="held part 'w' must be the state's first part"):
        declare(Scheme("bad", state=layout(p=4, w=3), held="w", deriv=None, encode=None, decode=None))
    with pytest.raises(ValueError, match="positive sizes"):
        layout(p=0)
