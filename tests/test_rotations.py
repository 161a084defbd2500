"""Attitude mathematics against scipy.spatial.transform.Rotation (the oracle), finite differences
(for every kinematic rate) and the seeds' worked examples.

Tolerances are tied to machine epsilon where the math allows (``TIGHT``), and to the printed digits of
a seed where the truth is a seed table.
"""

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from xcheck import rotations as rot
from xcheck.rotations import EULER_SEQUENCES

EPS = np.finfo(float).eps
TIGHT = 64 * EPS  # conversions of unit quantities: a few dozen roundings at most

SCIPY_AXES = {"1": "X", "2": "Y", "3": "Z"}


def scipy_seq(seq):
    """Our intrinsic '323' is scipy's intrinsic (upper-case) 'ZYZ'."""
    return "".join(SCIPY_AXES[c] for c in seq)


def as_scipy(q):
    return Rotation.from_quat(np.asarray(q)[..., [1, 2, 3, 0]])


def same_rotation(qa, qb):
    """Quaternions of the same rotation are equal up to sign."""
    qa, qb = np.asarray(qa), np.asarray(qb)
    return np.minimum(np.abs(qa - qb).max(-1), np.abs(qa + qb).max(-1))


quats = arrays(np.float64, 4, elements=st.floats(-1, 1)).filter(lambda q: np.linalg.norm(q) > 0.1)
quat_stacks = arrays(np.float64, st.tuples(st.integers(1, 3), st.integers(1, 4), st.just(4)),
                     elements=st.floats(-1, 1)).filter(lambda q: np.all(np.linalg.norm(q, axis=-1) > 0.1))
vectors = arrays(np.float64, 3, elements=st.floats(-3, 3))
angle_triples = arrays(np.float64, 3, elements=st.floats(-np.pi, np.pi))
sequences = st.sampled_from(EULER_SEQUENCES)


# ------------------------------------------------------------------------------------------------
# quaternions and DCMs against scipy
# ------------------------------------------------------------------------------------------------
@given(quat_stacks)
def test_quat_to_dcm_matches_scipy_and_keeps_batch_shape(q):
    R = rot.quat_to_dcm(q)
    assert R.shape == q.shape[:-1] + (3, 3)
    np.testing.assert_allclose(R, as_scipy(q.reshape(-1, 4)).as_matrix().reshape(R.shape), atol=TIGHT)


@given(quat_stacks)
def test_dcm_to_quat_round_trip_and_scipy(q):
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    back = rot.dcm_to_quat(rot.quat_to_dcm(q))
    assert back.shape == q.shape
    assert np.all(back[..., 0] >= 0)
    assert same_rotation(back, qn).max() < TIGHT
    ref = Rotation.from_matrix(rot.quat_to_dcm(q).reshape(-1, 3, 3)).as_quat(scalar_first=True)
    assert same_rotation(back.reshape(-1, 4), ref).max() < TIGHT


@given(quats, quats)
def test_quat_mul_composes_like_matrix_product(p, q):
    R = rot.quat_to_dcm(rot.quat_mul(p, q))
    np.testing.assert_allclose(R, rot.quat_to_dcm(p) @ rot.quat_to_dcm(q), atol=TIGHT)


@given(quats, vectors)
def test_quat_rotate_is_R_times_v_and_seed000_sandwich(q, v):
    qn = q / np.linalg.norm(q)
    np.testing.assert_allclose(rot.quat_rotate(q, v), rot.quat_to_dcm(q) @ v, atol=TIGHT * 10)
    # seed 000 §1.3.3: r_V = q^-1 r_I q maps world (I) components to body (V) components
    r_body = rot.quat_mul(rot.quat_mul(rot.quat_inv(qn), np.r_[0.0, v]), qn)[1:]
    np.testing.assert_allclose(r_body, rot.quat_to_dcm(q).T @ v, atol=TIGHT * 10)


def test_quat_conj_inv_normalize():
    q = np.array([1.0, -2.0, 3.0, 0.5])
    np.testing.assert_allclose(rot.quat_mul(q, rot.quat_inv(q)), [1, 0, 0, 0], atol=TIGHT)
    np.testing.assert_array_equal(rot.quat_conj(q), [1.0, 2.0, -3.0, -0.5])
    np.testing.assert_allclose(np.linalg.norm(rot.quat_normalize(q)), 1.0, atol=EPS)


# ------------------------------------------------------------------------------------------------
# Euler angles: all 12 sequences
# ------------------------------------------------------------------------------------------------
@given(angle_triples, sequences)
def test_euler_to_dcm_and_quat_match_scipy(angles, seq):
    ref = Rotation.from_euler(scipy_seq(seq), angles)
    np.testing.assert_allclose(rot.euler_to_dcm(angles, seq), ref.as_matrix(), atol=TIGHT)
    assert same_rotation(rot.euler_to_quat(angles, seq), ref.as_quat(scalar_first=True)) < TIGHT


@given(quats, sequences)
def test_quat_to_euler_matches_scipy_away_from_gimbal_lock(q, seq):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = rot.quat_to_euler(q, seq, warn=False)
        ref = as_scipy(q).as_euler(scipy_seq(seq))
    middle_singular = 0.0 if seq[0] == seq[2] else np.pi / 2
    distance = min(abs(abs(ours[1]) - middle_singular), abs(ours[1] - np.pi))
    # the rotation is always reproduced ...
    np.testing.assert_allclose(rot.euler_to_dcm(ours, seq), rot.quat_to_dcm(q), atol=TIGHT * 4)
    # ... and away from gimbal lock the angles are scipy's (angle sensitivity ~ eps / distance)
    if distance > 1e-3:
        d = np.angle(np.exp(1j * (ours - ref)))  # compare modulo 2 pi
        np.testing.assert_allclose(d, 0, atol=1e-12)


@given(st.sampled_from(EULER_SEQUENCES), st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi),
       st.sampled_from([0.0, 1e-15, 1e-12, 1e-9, 1e-7, 1e-5, -1e-9]), st.booleans())
def test_euler_near_gimbal_lock_reproduces_the_dcm(seq, a, c, offset, at_pi):
    """Near and at gimbal lock the angles are finite and reproduce the DCM (compare DCMs, not angles)."""
    if seq[0] == seq[2]:
        b = (np.pi - abs(offset)) if at_pi else abs(offset)
    else:
        b = (np.pi / 2 - abs(offset)) * (1 if at_pi else -1)
    R = rot.euler_to_dcm([a, b, c], seq)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rot.GimbalLockWarning)
        angles = rot.dcm_to_euler(R, seq)
    assert np.all(np.isfinite(angles))
    np.testing.assert_allclose(rot.euler_to_dcm(angles, seq), R, atol=TIGHT * 8)


def test_gimbal_lock_warns_and_zeroes_the_third_angle():
    R = rot.euler_to_dcm([0.3, 0.0, 0.4], "323")
    with pytest.warns(rot.GimbalLockWarning, match="third angle is set to zero"):
        angles = rot.dcm_to_euler(R, "323")
    np.testing.assert_allclose(angles, [0.7, 0.0, 0.0], atol=TIGHT)
    R = rot.euler_to_dcm([0.3, np.pi / 2, 0.4], "321")  # asymmetric: lock at +pi/2
    with pytest.warns(rot.GimbalLockWarning):
        angles = rot.dcm_to_euler(R, "321")
    assert angles[2] == 0.0
    np.testing.assert_allclose(rot.euler_to_dcm(angles, "321"), R, atol=TIGHT)


def test_euler_batch_shapes_are_kept():
    rng = np.random.default_rng(1)
    angles = rng.uniform(0.1, 1.4, (2, 5, 3))  # inside every sequence's principal range
    for seq in EULER_SEQUENCES:
        q = rot.euler_to_quat(angles, seq)
        assert q.shape == (2, 5, 4)
        back = rot.quat_to_euler(q, seq)
        assert back.shape == (2, 5, 3)
        np.testing.assert_allclose(back, angles, atol=1e-13)
        assert rot.euler_rate_matrix(angles, seq).shape == (2, 5, 3, 3)


# ------------------------------------------------------------------------------------------------
# rotation vector, Gibbs, MRP
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.0999, 0.1, 0.1001, 1.0, 3.0,
                                   np.pi - 1e-6, np.pi - 1e-9])
def test_rotvec_small_and_near_pi_angles(angle):
    axis = np.array([0.36, -0.48, 0.8])
    phi = angle * axis
    ref = Rotation.from_rotvec(phi)
    q = rot.rotvec_to_quat(phi)
    assert same_rotation(q, ref.as_quat(scalar_first=True)) < TIGHT
    np.testing.assert_allclose(rot.rotvec_to_dcm(phi), ref.as_matrix(), atol=TIGHT)
    back = rot.quat_to_rotvec(q)
    np.testing.assert_allclose(back, phi, rtol=1e-13, atol=1e-300)
    np.testing.assert_allclose(rot.dcm_to_rotvec(rot.rotvec_to_dcm(phi)), phi, rtol=1e-7 if angle > 3 else 1e-12,
                               atol=1e-15)


@given(quat_stacks)
def test_rotvec_round_trip(q):
    phi = rot.quat_to_rotvec(q)
    assert np.all(np.linalg.norm(phi, axis=-1) <= np.pi + 1e-12)
    assert same_rotation(rot.rotvec_to_quat(phi), rot.quat_normalize(q)).max() < TIGHT


@given(quats)
def test_gibbs_round_trip_and_dcm_of_seed000(q):
    qn = q / np.linalg.norm(q)
    if abs(qn[0]) <= np.sin(0.5e-6):  # within 1e-6 rad of a 180 deg rotation
        with pytest.raises(ValueError, match="180"):
            rot.quat_to_gibbs(q)
        return
    g = rot.quat_to_gibbs(q)
    assert same_rotation(rot.gibbs_to_quat(g), qn) < 1e-12
    if np.linalg.norm(g) > 100:
        return  # the Cayley inverse below is conditioned like |g|^2
    # seed 000 §1.4.1: D_I^V = (I - G)(I + G)^-1 with G = -[g x]: our body->world R (Cayley form)
    G = -rot.skew(g)
    np.testing.assert_allclose((np.eye(3) - G) @ np.linalg.inv(np.eye(3) + G), rot.quat_to_dcm(q), atol=1e-10)


def test_gibbs_is_singular_at_180_degrees():
    with pytest.raises(ValueError, match="singular at a 180"):
        rot.quat_to_gibbs([0.0, 1.0, 0.0, 0.0])


@given(quats)
def test_mrp_round_trip_and_shadow_set(q):
    qn = q / np.linalg.norm(q)
    s = rot.quat_to_mrp(q)
    assert np.linalg.norm(s) <= 1 + 1e-15
    assert same_rotation(rot.mrp_to_quat(s), qn) < 1e-12
    if abs(abs(qn[0]) - 1) > 1e-6:
        shadow = rot.quat_to_mrp(q, shadow=True)
        assert np.linalg.norm(shadow) >= 1 - 1e-15
        assert same_rotation(rot.mrp_to_quat(shadow), qn) < 1e-10
        np.testing.assert_allclose(rot.mrp_shadow(s), shadow, rtol=1e-10)
    np.testing.assert_allclose(s, Rotation.from_quat(qn[[1, 2, 3, 0]]).as_mrp(), atol=1e-12)


# ------------------------------------------------------------------------------------------------
# attitude distance and normalisation (seed 000 §1.7)
# ------------------------------------------------------------------------------------------------
@given(quats, quats)
def test_attitude_error_is_the_geodesic_angle(qa, qb):
    err = rot.attitude_error(qa, qb)
    ref = (as_scipy(qa).inv() * as_scipy(qb)).magnitude()
    assert abs(err - ref) < 1e-7  # scipy's magnitude uses arccos-free atan2 too; both are the angle
    assert rot.attitude_error(qa, -qb) == pytest.approx(err, abs=TIGHT)
    assert 0 <= err <= np.pi


@pytest.mark.parametrize("angle", [1e-14, 1e-10, 1e-6, 0.5, 3.0])
def test_attitude_error_small_angles_exact(angle):
    q0 = rot.quat_normalize([0.3, -0.2, 0.9, 0.1])
    q1 = rot.quat_mul(q0, rot.rotvec_to_quat(angle * np.array([0.0, 0.6, 0.8])))
    assert rot.attitude_error(q0, q1) == pytest.approx(angle, rel=1e-9)


@given(quats, st.integers(0, 2**31))
def test_bjorck_converges_to_the_svd_polar_factor(q, seed):
    R = rot.quat_to_dcm(q)
    X = R + np.random.default_rng(seed).normal(0, 0.05, (3, 3))
    B = rot.orthonormalize_dcm(X, "bjorck")
    S = rot.orthonormalize_dcm(X, "svd")
    np.testing.assert_allclose(B, S, atol=1e-13)
    np.testing.assert_allclose(B.T @ B, np.eye(3), atol=10 * EPS * 4)


@given(quats, st.floats(0.5, 1.6))
def test_savage_converges_to_the_normalised_quaternion(q, scale):
    qs = q / np.linalg.norm(q) * scale
    np.testing.assert_allclose(rot.quat_normalize_savage(qs), q / np.linalg.norm(q), atol=8 * EPS)


# ------------------------------------------------------------------------------------------------
# kinematic rates against finite differences along a smooth rotation
# ------------------------------------------------------------------------------------------------
A_WORLD = np.array([0.3, -0.7, 0.45])  # [rad/s]
B_BODY = np.array([-0.2, 0.5, 1.1])  # [rad/s]
Q0 = rot.quat_normalize([0.6, 0.2, -0.5, 0.3])


def path(t):
    """R(t) = exp(t a) R0 exp(t b): body rate omega(t) = R(t)^T a + b exactly."""
    q = rot.quat_mul(rot.quat_mul(rot.rotvec_to_quat(t * A_WORLD), Q0), rot.rotvec_to_quat(t * B_BODY))
    omega = rot.quat_to_dcm(q).T @ A_WORLD + B_BODY
    return q, omega


def central_difference(f, t, h=1e-5):
    return (f(t + h) - f(t - h)) / (2 * h)


FD_TOL = 2e-8  # central difference, h = 1e-5: truncation ~ h^2 |f'''| / 6, round-off ~ eps / h


@pytest.mark.parametrize("t", [0.0, 0.7, 2.3])
def test_quat_and_dcm_rates_against_finite_differences(t):
    q, omega = path(t)
    sign = np.sign(q[0])
    fq = lambda s: path(s)[0] * np.sign(path(s)[0][0]) * sign  # noqa: E731  (continuous branch)
    np.testing.assert_allclose(rot.quat_rate(q, omega), central_difference(fq, t), atol=FD_TOL)
    fR = lambda s: rot.quat_to_dcm(path(s)[0])  # noqa: E731
    np.testing.assert_allclose(rot.dcm_rate(rot.quat_to_dcm(q), omega), central_difference(fR, t), atol=FD_TOL)


@pytest.mark.parametrize("t", [0.0, 0.7, 2.3])
@pytest.mark.parametrize("seq", EULER_SEQUENCES)
def test_euler_rates_against_finite_differences(seq, t):
    q, omega = path(t)
    angles = rot.quat_to_euler(q, seq)

    def f(s):
        d = rot.quat_to_euler(path(s)[0], seq) - angles
        return np.angle(np.exp(1j * d))  # continuous across the +-pi wrap

    fd = central_difference(f, t)
    np.testing.assert_allclose(rot.omega_to_euler_rates(angles, omega, seq), fd, atol=1e-7)
    np.testing.assert_allclose(rot.euler_rates_to_omega(angles, fd, seq), omega, atol=1e-7)


@pytest.mark.parametrize("t", [0.0, 0.7, 2.3])
def test_gibbs_mrp_rotvec_rates_against_finite_differences(t):
    q, omega = path(t)
    for to_p, rate in [(rot.quat_to_gibbs, rot.gibbs_rate), (rot.quat_to_mrp, rot.mrp_rate),
                       (rot.quat_to_rotvec, rot.rotvec_rate)]:
        fd = central_difference(lambda s: to_p(path(s)[0]), t)
        np.testing.assert_allclose(rate(to_p(q), omega), fd, atol=FD_TOL, err_msg=to_p.__name__)


def test_seed000_gibbs_rate_matrix_has_the_wrong_skew_sign():
    """Seed 000 §1.4.2 prints 1/2 (I + g g^T - [g x]) omega; the finite difference says +[g x]."""
    q, omega = path(0.7)
    g = rot.quat_to_gibbs(q)
    fd = central_difference(lambda s: rot.quat_to_gibbs(path(s)[0]), 0.7)
    g1, g2, g3 = g
    printed = 0.5 * np.array([[1 + g1**2, g3 + g1 * g2, -g2 + g1 * g3],
                              [-g3 + g1 * g2, 1 + g2**2, g1 + g2 * g3],
                              [g2 + g1 * g3, -g1 + g2 * g3, 1 + g3**2]]) @ omega
    assert np.abs(printed - fd).max() > 0.1
    np.testing.assert_allclose(rot.gibbs_rate(g, omega), fd, atol=FD_TOL)


def test_rotvec_rate_small_angle_series_and_seed000_form():
    omega = np.array([0.3, -1.2, 0.8])
    for angle in [0.0, 1e-8, 1e-3, 0.0999, 0.1001, 1.0, 3.0]:
        phi = angle * np.array([0.48, 0.6, 0.64])
        got = rot.rotvec_rate(phi, omega)
        if angle > 0.5:  # seed 000 §1.5.2 as printed, where it is well conditioned
            pxw = np.cross(phi, omega)
            printed = omega + 0.5 * pxw + np.cross(phi, pxw) / angle**2 * (
                1 - angle * np.sin(angle) / (2 * (1 - np.cos(angle))))
            np.testing.assert_allclose(got, printed, rtol=1e-13)
        # long-double evaluation of the coefficient as the truth
        x = np.longdouble(angle)
        c = (1 - (x / 2) * np.cos(x / 2) / np.sin(x / 2)) / x**2 if angle > 1e-3 else np.longdouble(1) / 12
        pxw = np.cross(phi, omega)
        expect = omega + 0.5 * pxw + float(c) * np.cross(phi, pxw)
        np.testing.assert_allclose(got, expect, rtol=1e-14, atol=1e-300)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-4, 0.0999, 0.1001, 0.5, 2.0, 3.1, 4.0])
def test_dexp_and_dexp_inv(angle):
    u = angle * np.array([0.0, 0.6, -0.8])
    np.testing.assert_allclose(rot.dexp(u) @ rot.dexp_inv(u), np.eye(3), atol=TIGHT)
    # omega of R(t) = exp(u0 + t v) is dexp(-u) v  (seed 004 eq. 166-167 invert it)
    v = np.array([0.4, -0.3, 0.9])
    fR = lambda s: rot.rotvec_to_dcm(u + s * v)  # noqa: E731
    Rdot = central_difference(fR, 0.0)
    W = rot.rotvec_to_dcm(u).T @ Rdot
    omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
    np.testing.assert_allclose(rot.dexp(-u) @ v, omega, atol=FD_TOL)
    np.testing.assert_allclose(rot.dexp_inv(-u) @ omega, v, atol=5 * FD_TOL)
    # seed 004 eq. 167 as printed: (I + 1/2 u~ - (|u| cot(|u|/2) - 2)/(2|u|^2) u~^2) omega
    if angle > 0.5:
        U = rot.skew(u)
        printed = (np.eye(3) + 0.5 * U - (angle / np.tan(angle / 2) - 2) / (2 * angle**2) * U @ U) @ omega
        np.testing.assert_allclose(rot.dexp_inv(-u) @ omega, printed, rtol=1e-13)


def test_quat_exp_is_seed004_eq170():
    u = np.array([0.2, -0.4, 0.3])
    n = np.linalg.norm(u)
    eq170 = np.r_[np.cos(n / 2), np.sin(n / 2) * u / n]
    np.testing.assert_allclose(rot.quat_exp(u), eq170, atol=TIGHT)
    np.testing.assert_allclose(rot.quat_log(rot.quat_exp(u)), u, atol=TIGHT)


def test_omega_to_euler_rates_reports_the_singularity():
    with pytest.raises(rot.EulerSingularityError, match="singular at middle angle 0") as info:
        rot.omega_to_euler_rates([0.0, 0.0, 0.0], [0.1, 0.2, 15.71], "323")
    assert info.value.middle_angle == 0.0 and info.value.sequence == "323"
    with pytest.raises(rot.EulerSingularityError):
        rot.omega_to_euler_rates([0.1, np.pi / 2, 0.2], [0.1, 0.2, 0.3], "321")
    # near (not at) the singularity it answers, with rates ~ 1/sin(theta)
    rates = rot.omega_to_euler_rates([0.0, 1e-5, 0.0], [1.0, 0.0, 0.0], "323")
    assert np.all(np.isfinite(rates)) and abs(rates[0]) > 1e4


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("call, match", [
    (lambda: rot.quat_to_dcm([1.0, 0.0, 0.0]), r"q: expected shape \(\.\.\., 4\)"),
    (lambda: rot.quat_to_dcm([np.nan, 0.0, 0.0, 1.0]), "q: contains non-finite"),
    (lambda: rot.quat_to_dcm([0.0, 0.0, 0.0, 0.0]), "q: a zero quaternion"),
    (lambda: rot.euler_to_dcm([0.1, 0.2, 0.3], "xyz"), "seq: expected one of 121, 131"),
    (lambda: rot.euler_to_dcm([0.1, 0.2, 0.3], "112"), "seq: expected one of"),
    (lambda: rot.euler_to_dcm([0.1, 0.2], "323"), r"angles: expected shape \(\.\.\., 3\)"),
    (lambda: rot.dcm_to_quat(np.ones((3, 3))), "R: not a rotation matrix"),
    (lambda: rot.dcm_to_quat(np.eye(4)), r"R: expected shape \(\.\.\., 3, 3\)"),
    (lambda: rot.attitude_error([1, 0, 0, 0], "abc"), "qb: expected an array"),
    (lambda: rot.orthonormalize_dcm(np.eye(3), "qr"), "method: expected 'bjorck' or 'svd'"),
    (lambda: rot.rotvec_rate([0.0, 0.0, 2 * np.pi], [1.0, 0, 0]), "singular at"),
])
def test_bad_input_is_a_clear_value_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()
