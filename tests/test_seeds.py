"""Each seed's convention converted at the boundary, checked on the seed's own worked numbers.

The truth in each test is a printed number of a seed (with its printed precision as tolerance) or an
exact identity; where a seed prints a mistake, the test shows the mistake and what is right instead.
"""

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck import seeds

DEG = np.pi / 180


# ------------------------------------------------------------------------------------------------
# seed 001 §7.1.1, §8.4.1, Tables 3-4: a 3x2x1 box rotated about fixed x, y, z by 30, 45, 60 deg
# ------------------------------------------------------------------------------------------------
BOX = np.array([[0, 0, 0], [3, 0, 0], [3, 2, 0], [0, 2, 0], [0, 0, 1], [3, 0, 1], [3, 2, 1], [0, 2, 1]], float)
# Table 4 as printed (3 decimals) ...
TABLE4_PRINTED = np.array([[0.000, 0.000, 0.000], [1.061, 1.837, 2.121], [-0.086, 3.316, 1.414],
                           [-1.146, 1.478, 0.707], [0.739, 0.280, 0.612], [1.800, 2.117, 1.509],
                           [0.653, 3.596, 0.802], [-0.407, 1.759, 1.319]])
# ... and with the minus signs the tables lost for B, C, F, G (§8.4.1 works C out to z = -1.414)
LOST_MINUS = np.array([1, 2, 5, 6])
TABLE4 = TABLE4_PRINTED.copy()
TABLE4[LOST_MINUS, 2] *= -1


def test_seed001_box_vertices_with_euler_angles():
    """Rotations about the fixed x, then y, then z axes: R = Rz(60) Ry(45) Rx(30), our '321' (active)."""
    R = rot.euler_to_dcm(np.array([60, 45, 30]) * DEG, "321")
    rotated = BOX @ R.T
    np.testing.assert_allclose(rotated, TABLE4, atol=5.1e-4)  # 3 printed decimals
    # the printed table's z of B, C, F, G has the wrong sign
    assert np.all(np.abs(rotated[LOST_MINUS, 2] - TABLE4_PRINTED[LOST_MINUS, 2]) > 1.0)
    # the seed's own R_xyz of §7.1.1 (its exact surds) is the passive matrix T_z T_y T_x of *body-axis*
    # rotations x, y', z'' (our intrinsic '123', transposed) -- not the fixed-axis rotation its tables use
    R_xyz = np.array([[np.sqrt(2) / 4, 3 / 4 + np.sqrt(2) / 8, -np.sqrt(6) / 8 + np.sqrt(3) / 4],
                      [-np.sqrt(6) / 4, -np.sqrt(6) / 8 + np.sqrt(3) / 4, 1 / 4 + 3 * np.sqrt(2) / 8],
                      [np.sqrt(2) / 2, -np.sqrt(2) / 4, np.sqrt(6) / 4]])
    np.testing.assert_allclose(R_xyz, rot.euler_to_dcm(np.array([30, 45, 60]) * DEG, "123").T, atol=1e-15)
    assert np.abs(R_xyz.T @ BOX[2] - TABLE4[2]).max() > 0.5


def test_seed001_section_8_4_1_vertex_C_by_quaternions():
    q = rot.euler_to_quat(np.array([60, 45, 30]) * DEG, "321")
    np.testing.assert_allclose(rot.quat_rotate(q, BOX[2]), [-0.086, 3.316, -1.414], atol=5.1e-4)
    # the intermediate result after the x and y rotations, (2.828; 1.732; -1.414)
    q_xy = rot.euler_to_quat(np.array([0, 45, 30]) * DEG, "321")
    np.testing.assert_allclose(rot.quat_rotate(q_xy, BOX[2]), [2.828, 1.732, -1.414], atol=5.1e-4)


def seed001_velocidade_angular(ang, dang):
    """Seed 001 appendix A, transcribed."""
    s, c = np.sin(ang), np.cos(ang)
    return np.array([dang[1] * s[2] - dang[0] * c[2] * s[1],
                     dang[1] * c[2] + dang[0] * s[2] * s[1],
                     dang[2] + dang[0] * c[1]])


def seed001_quaternion(ang):
    """Seed 001 appendix A ``quaternion(ang)``, transcribed (right only for psi = 0)."""
    s, c = np.sin(ang / 2), np.cos(ang / 2)
    return np.array([c[0] * c[1] * c[2] - s[0] * s[1] * s[2], c[0] * s[1] * s[2] - s[0] * c[1] * c[2],
                     c[0] * s[1] * c[2] - s[0] * c[1] * s[2], c[0] * c[1] * s[2] - s[0] * s[1] * c[2]])


@pytest.mark.parametrize("theta_deg", [15.0, 0.001, 47.0])
def test_seed001_appendix_is_our_323(theta_deg):
    ang = np.array([0.0, theta_deg, 0.0]) * DEG
    dang = np.array([0.02, 0.02, 15.71])
    np.testing.assert_allclose(rot.euler_rates_to_omega(ang, dang, "323"), seed001_velocidade_angular(ang, dang),
                               atol=1e-15)
    # with psi = 0 (all three initial conditions of the seed) its quaternion is ours
    np.testing.assert_allclose(rot.euler_to_quat(ang, "323"), seed001_quaternion(ang), atol=1e-15)
    # general angles: the rate relation still agrees; the seed's quaternion() does not
    ang = np.array([0.4, theta_deg * DEG, -1.1])
    np.testing.assert_allclose(rot.euler_rates_to_omega(ang, dang, "323"), seed001_velocidade_angular(ang, dang),
                               atol=1e-14)
    assert rot.attitude_error(rot.euler_to_quat(ang, "323"), seed001_quaternion(ang)) > 0.1


# ------------------------------------------------------------------------------------------------
# seed 004 eq. 26, 178-180
# ------------------------------------------------------------------------------------------------
def test_seed004_eq26_is_our_313():
    psi, theta, sigma = 0.3, -1.2, 2.1
    c, s = np.cos, np.sin
    eq26 = np.array([
        [c(psi) * c(sigma) - s(psi) * c(theta) * s(sigma), -c(psi) * s(sigma) - s(psi) * c(theta) * c(sigma),
         s(psi) * s(theta)],
        [s(psi) * c(sigma) + c(psi) * c(theta) * s(sigma), -s(psi) * s(sigma) + c(psi) * c(theta) * c(sigma),
         -c(psi) * s(theta)],
        [s(theta) * s(sigma), s(theta) * c(sigma), c(theta)]])
    np.testing.assert_allclose(rot.euler_to_dcm([psi, theta, sigma], "313"), eq26, atol=1e-15)


def test_seed004_eq77_is_our_quat_to_dcm_and_R_equals_E_G_transpose():
    p = rot.quat_normalize([0.3, -0.5, 0.7, 0.2])
    e0, e = p[0], p[1:]
    et = rot.skew(e)
    E = np.hstack([-e[:, None], et + e0 * np.eye(3)])  # eq. 93
    G = np.hstack([-e[:, None], -et + e0 * np.eye(3)])  # eq. 94
    np.testing.assert_allclose(E @ G.T, rot.quat_to_dcm(p), atol=1e-15)  # eq. 111


def test_seed004_eq179_and_the_sign_of_eq178():
    sigma, theta, psi = np.array([-135.0, 35.0, -70.0]) * DEG  # eq. 180
    p179 = seeds.seed004_eq179(sigma, theta, psi)
    # eq. 179 is the 3-2-1 (yaw psi, pitch theta, roll sigma) quaternion, not the 3-1-3 of eq. 22-26
    np.testing.assert_allclose(p179, rot.euler_to_quat([psi, theta, sigma], "321"), atol=1e-15)
    assert rot.attitude_error(p179, rot.euler_to_quat([psi, theta, sigma], "313")) > 0.1
    # eq. 179 gives +0.4583 first; the printed eq. 178 has -0.4583 and otherwise the same digits
    np.testing.assert_allclose(p179, [0.4583, -0.6558, 0.5997, 0.0182], atol=5e-5)
    p178 = seeds.SEED004_P0_PRINTED
    assert p179[0] > 0 > p178[0]
    # so eq. 178 is a different rotation (1.904 rad away): the conjugate (inverse) of eq. 179, up to sign
    assert rot.attitude_error(p179, p178) == pytest.approx(1.9043, abs=1e-4)
    np.testing.assert_allclose(-rot.quat_conj(p179), p178, atol=5e-5)


# ------------------------------------------------------------------------------------------------
# seed 002 eq. 1.6-1.10: scalar-last quaternion, inertial -> body attitude matrix
# ------------------------------------------------------------------------------------------------
R12_PRINTED = np.array([[0.4156, -0.8551, 0.3100], [-0.8339, -0.4943, -0.2455], [0.3631, -0.1566, -0.9185]])
Q12_PRINTED = np.array([-0.8409, 0.5022, -0.2001, 0.0264])  # eq. 1.9, [q1, q2, q3, q4], q4 = +-0.0264


def test_seed002_eq1_8_quaternion_of_R12_converted_at_the_boundary():
    R_body_to_world = seeds.seed002_matrix_to_dcm(rot.orthonormalize_dcm(R12_PRINTED, "svd"))
    q = rot.dcm_to_quat(R_body_to_world)
    expected = seeds.seed002_quat_to_quat(Q12_PRINTED)
    np.testing.assert_allclose(q, expected, atol=2e-4)  # 4 printed digits, and R12 is only near-orthogonal


def test_seed002_eq1_10_matrix_is_our_dcm_transposed():
    q_last = rot.quat_normalize([0.3, -0.1, 0.8, 0.5])  # any unit quaternion, seed 002's order
    ours = seeds.seed002_quat_to_quat(q_last)
    np.testing.assert_allclose(seeds.seed002_attitude_matrix(q_last), rot.quat_to_dcm(ours).T, atol=1e-15)
    np.testing.assert_allclose(seeds.quat_to_seed002_quat(ours), q_last, atol=0)
    # and on the printed numbers: eq. 1.10 of q12 reproduces R12 to the printed digits
    np.testing.assert_allclose(seeds.seed002_attitude_matrix(Q12_PRINTED / np.linalg.norm(Q12_PRINTED)),
                               R12_PRINTED, atol=4e-4)
