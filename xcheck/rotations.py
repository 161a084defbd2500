"""Attitude mathematics: every parametrization of the seeds, their conversions and kinematics.

Conventions (stated once, used everywhere in xcheck)
----------------------------------------------------
* Quaternion ``q = [w, x, y, z]``: scalar first (like MuJoCo), unit norm, Hamilton product
  (``i j = k``), *active* and *body -> world*.
* ``R = quat_to_dcm(q)`` maps body components to world components: ``v_world = R @ v_body``
  (the convention of MuJoCo's ``xmat``). ``quat_mul(p, q)`` composes like ``R(p) @ R(q)``.
* Angular velocity ``omega`` is the body rate *in body components* (MuJoCo's free-joint ``qvel[3:6]``).
* Euler angles: ``seq`` is three axis digits in the seeds' notation (``"323"``, ``"313"``, ``"321"``, ...),
  intrinsic rotations about body axes, first rotation first:
  ``euler_to_dcm([a, b, c], "323") == Rz(a) @ Ry(b) @ Rz(c)``. Angles in radians.
* Rotation (Euler) vector ``phi = angle * axis`` with ``R = exp([phi x])``; Gibbs (Rodrigues) vector
  ``g = tan(angle/2) * axis``; modified Rodrigues parameters ``s = tan(angle/4) * axis``.
* SI units everywhere.

Each seed uses its own convention; the converters at the seed boundary live in :mod:`xcheck.seeds`.

Every function takes stacks: leading dimensions of ``(..., 4)``, ``(..., 3)`` and ``(..., 3, 3)``
arguments are kept. Bad input (wrong shape, non-finite values, a zero quaternion) raises
:class:`ValueError` naming the argument and the expected shape.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = [
    "frame_with_z",
    "EULER_SEQUENCES",
    "GIMBAL_LOCK_TOL",
    "GimbalLockWarning",
    "EulerSingularityError",
    "skew",
    "quat_mul",
    "quat_conj",
    "quat_inv",
    "quat_normalize",
    "quat_normalize_savage",
    "quat_rotate",
    "quat_to_dcm",
    "dcm_to_quat",
    "axis_rotation",
    "euler_to_dcm",
    "dcm_to_euler",
    "euler_to_quat",
    "quat_to_euler",
    "rotvec_to_quat",
    "quat_to_rotvec",
    "rotvec_to_dcm",
    "dcm_to_rotvec",
    "gibbs_to_quat",
    "quat_to_gibbs",
    "mrp_to_quat",
    "quat_to_mrp",
    "mrp_shadow",
    "orthonormalize_dcm",
    "attitude_error",
    "quat_exp",
    "quat_log",
    "dexp",
    "dexp_inv",
    "quat_rate",
    "dcm_rate",
    "euler_rate_matrix",
    "euler_rates_to_omega",
    "omega_to_euler_rates",
    "gibbs_rate",
    "mrp_rate",
    "rotvec_rate",
]

EPS = np.finfo(float).eps

#: The 12 valid Euler sequences (seed 000 §1.2): 6 symmetric (first axis = third), 6 asymmetric.
EULER_SEQUENCES = ("121", "131", "212", "232", "313", "323", "123", "132", "213", "231", "312", "321")

#: Middle-angle distance [rad] from the singular value below which an Euler conversion is gimbal-locked.
GIMBAL_LOCK_TOL = 1e-7

#: Middle-angle distance [rad] from the singular value treated as exactly singular (a few ulps).
_EXACT_LOCK = 16 * EPS

#: Below this angle [rad] the series branches of the so(3) coefficient functions are used.
_SERIES_ANGLE = 0.1


class GimbalLockWarning(UserWarning):
    """Euler angles were requested at gimbal lock; the third angle was set to zero."""


class EulerSingularityError(ValueError):
    """Euler-angle rates are undefined: the first and third rotation axes coincide.

    Attributes
    ----------
    middle_angle : float
        The middle Euler angle [rad] at the (first) singular point.
    sequence : str
        The Euler sequence.
    """

    def __init__(self, message: str, *, middle_angle: float, sequence: str):
        super().__init__(message)
        self.middle_angle = middle_angle
        self.sequence = sequence


# --------------------------------------------------------------------------------------------
# input validation
# --------------------------------------------------------------------------------------------
def _check(x, name: str, tail: tuple[int, ...]) -> np.ndarray:
    """Return ``x`` as a finite float array whose trailing shape is ``tail``; else ValueError."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of shape (..., {', '.join(map(str, tail))}) "
                         f"of real numbers, got {type(x).__name__}") from exc
    if a.ndim < len(tail) or a.shape[a.ndim - len(tail):] != tail:
        raise ValueError(f"{name}: expected shape (..., {', '.join(map(str, tail))}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains non-finite values (NaN or inf)")
    return a


def _check_seq(seq) -> tuple[int, int, int]:
    """Axis indices (0-based) of an Euler sequence string like ``"323"``."""
    if not isinstance(seq, str) or seq not in EULER_SEQUENCES:
        raise ValueError(f"seq: expected one of {', '.join(EULER_SEQUENCES)}, got {seq!r}")
    return int(seq[0]) - 1, int(seq[1]) - 1, int(seq[2]) - 1


def _unit_quat(q, name: str = "q") -> np.ndarray:
    """``q / |q|`` without overflow or underflow (scaled by its largest component first); a zero
    quaternion is a ValueError."""
    q = _check(q, name, (4,))
    scale = np.max(np.abs(q), axis=-1, keepdims=True)
    if np.any(scale == 0):
        raise ValueError(f"{name}: a zero quaternion does not represent a rotation")
    q = q / scale
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.sum(v * v, axis=-1))


def _series_square(x: np.ndarray, small: np.ndarray) -> np.ndarray:
    """``x**2`` where ``small`` holds, 0 elsewhere: a series' argument, never squared where the series is not used
    (an angle of a blown-up run would overflow there, and warn, for a value thrown away)."""
    xz = np.where(small, x, 0.0)
    return xz * xz


def _safe(x: np.ndarray, small: np.ndarray) -> np.ndarray:
    """``x`` with the entries where ``small`` holds replaced by 1 (a denominator never zero)."""
    return np.where(small, 1.0, x)


# --------------------------------------------------------------------------------------------
# so(3) coefficient functions, each with a series branch for small angles (seed 000 §1.5.1)
# --------------------------------------------------------------------------------------------
def _sinc(x):
    """sin(x)/x."""
    small = x < _SERIES_ANGLE
    xs = _safe(x, small)
    x2 = _series_square(x, small)
    return np.where(small, 1 - x2 / 6 * (1 - x2 / 20 * (1 - x2 / 42 * (1 - x2 / 72))), np.sin(xs) / xs)


def _one_minus_cos_over_x2(x):
    """(1 - cos x)/x**2 = 2 sin(x/2)**2 / x**2 (no cancellation)."""
    small = x < _SERIES_ANGLE
    xs = _safe(x, small)
    x2 = _series_square(x, small)
    series = 0.5 - x2 / 24 * (1 - x2 / 30 * (1 - x2 / 56 * (1 - x2 / 90)))
    return np.where(small, series, 2 * np.sin(xs / 2) ** 2 / (xs * xs))


def _x_minus_sin_over_x3(x):
    """(x - sin x)/x**3."""
    small = x < _SERIES_ANGLE
    xs = _safe(x, small)
    x2 = _series_square(x, small)
    series = 1 / 6 - x2 / 120 * (1 - x2 / 42 * (1 - x2 / 72 * (1 - x2 / 110)))
    return np.where(small, series, (xs - np.sin(xs)) / xs**3)


def _dexp_inv_coefficient(x):
    """(1 - (x/2) cot(x/2)) / x**2, the u~**2 coefficient of dexp^-1 (seed 004 eq. 167, seed 000 §1.5.2)."""
    small = x < _SERIES_ANGLE
    xs = _safe(x, small)
    x2 = _series_square(x, small)
    series = 1 / 12 + x2 / 720 + x2**2 / 30240 + x2**3 / 1209600 + x2**4 / 47900160
    # (x/2) cot(x/2) = (x/2) cos(x/2) / sin(x/2); sin(x/2) > 0 for 0 < x < 2 pi
    half = xs / 2
    direct = (1 - half * np.cos(half) / np.sin(half)) / (xs * xs)
    return np.where(small, series, direct)


# --------------------------------------------------------------------------------------------
# quaternion algebra (seed 000 §1.3.1; seed 004 eq. 34)
# --------------------------------------------------------------------------------------------
def skew(v):
    """Skew-symmetric (cross-product) matrix ``[v x]``, shape ``(..., 3) -> (..., 3, 3)``."""
    v = _check(v, "v", (3,))
    z = np.zeros_like(v[..., 0])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def _qmul(p, q):
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], axis=-1)


def quat_mul(p, q):
    """Hamilton product ``p ⊗ q`` (seed 004 eq. 34); ``quat_to_dcm(quat_mul(p, q)) == R(p) @ R(q)``.

    Shapes ``(..., 4)`` broadcast against each other.
    """
    return _qmul(_check(p, "p", (4,)), _check(q, "q", (4,)))


def quat_conj(q):
    """Conjugate ``[w, -x, -y, -z]`` (the inverse of a unit quaternion), shape ``(..., 4)``."""
    q = _check(q, "q", (4,))
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_inv(q):
    """Inverse ``q* / |q|^2`` (seed 000 §1.3.1), shape ``(..., 4)``."""
    q = _check(q, "q", (4,))
    n2 = np.sum(q * q, axis=-1, keepdims=True)
    if np.any(n2 < 1e-24):
        raise ValueError("q: a zero quaternion has no inverse")
    return q * np.array([1.0, -1.0, -1.0, -1.0]) / n2


def quat_normalize(q):
    """Unit quaternion ``q / |q|``, shape ``(..., 4)``; a zero quaternion is a ValueError."""
    return _unit_quat(q)


def quat_normalize_savage(q, *, tol: float = 4 * EPS, max_iter: int = 60):
    """Savage's iterative quaternion normalisation (seed 000 §1.7.2).

    ``X_{j+1} = 1.5 X_j - 0.5 X_j X_j* X_j``, which for quaternions is ``X (1.5 - 0.5 |X|^2)``; it
    converges (quadratically near 1) to ``q/|q|`` for ``0 < |q| < sqrt(3)``.
    """
    x = _check(q, "q", (4,)).copy()
    n2 = np.sum(x * x, axis=-1, keepdims=True)
    if np.any(n2 <= 0) or np.any(n2 >= 3):
        raise ValueError("q: Savage's iteration converges only for 0 < |q| < sqrt(3)")
    for _ in range(max_iter):
        x = 1.5 * x - 0.5 * _qmul(_qmul(x, x * np.array([1.0, -1.0, -1.0, -1.0])), x)
        if np.all(np.abs(np.sum(x * x, axis=-1) - 1) <= tol):
            return x
    raise ValueError(f"q: Savage's iteration did not converge in {max_iter} iterations")


def quat_rotate(q, v):
    """Rotate body components to world components: ``R(q) @ v``; shapes ``(..., 4)``, ``(..., 3)``."""
    q = _unit_quat(q)
    v = _check(v, "v", (3,))
    w, u = q[..., :1], q[..., 1:]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_to_dcm(q):
    """Rotation matrix (DCM) of a quaternion (seed 004 eq. 77), shape ``(..., 4) -> (..., 3, 3)``.

    ``R`` maps body components to world components, ``v_world = R @ v_body``. ``q`` is normalised first.
    """
    q = _unit_quat(q)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _check_rotation_matrix(R, name: str = "R", tol: float = 1e-6) -> np.ndarray:
    R = _check(R, name, (3, 3))
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-2, -1)) if R.size else np.zeros(0)
    if np.any(err > tol) or np.any(np.linalg.det(R) <= 0):
        raise ValueError(f"{name}: not a rotation matrix (|R^T R - I| up to {np.max(err):.2e}, or det <= 0); "
                         "use orthonormalize_dcm first")
    return R


def dcm_to_quat(R):
    """Quaternion of a rotation matrix (Shepperd's method), ``(..., 3, 3) -> (..., 4)``, with ``w >= 0``.

    The trace relation of seed 004 eq. 83-85 chooses the largest of ``w, x, y, z`` first, so no
    component is computed from a small square root.
    """
    R = _check_rotation_matrix(R)
    r00, r11, r22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    cands = np.stack([
        np.stack([1 + tr, R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1),
        np.stack([R[..., 2, 1] - R[..., 1, 2], 1 + 2 * r00 - tr, R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0]], -1),
        np.stack([R[..., 0, 2] - R[..., 2, 0], R[..., 0, 1] + R[..., 1, 0], 1 + 2 * r11 - tr, R[..., 1, 2] + R[..., 2, 1]], -1),
        np.stack([R[..., 1, 0] - R[..., 0, 1], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1], 1 + 2 * r22 - tr], -1),
    ], -2)
    best = np.argmax(np.stack([tr, r00, r11, r22], -1), axis=-1)
    q = np.take_along_axis(cands, best[..., None, None], axis=-2)[..., 0, :]
    q = q / _norm(q)[..., None]
    return np.where(q[..., :1] < 0, -q, q)


# --------------------------------------------------------------------------------------------
# Euler angles: the 12 sequences from one axis table (seed 000 §1.2, seed 001 §7, seed 004 eq. 22-30)
# --------------------------------------------------------------------------------------------
def axis_rotation(axis: int, angle):
    """Active rotation by ``angle`` [rad] about body axis ``axis`` (1, 2 or 3): ``(...,) -> (..., 3, 3)``."""
    if axis not in (1, 2, 3):
        raise ValueError(f"axis: expected 1, 2 or 3, got {axis!r}")
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    i, j, k = axis - 1, axis % 3, (axis + 1) % 3
    R = np.zeros(angle.shape + (3, 3))
    R[..., i, i] = 1
    R[..., j, j] = c
    R[..., k, k] = c
    R[..., j, k] = -s
    R[..., k, j] = s
    return R


def _axis_quat(axis: int, angle):
    q = np.zeros(np.shape(angle) + (4,))
    q[..., 0] = np.cos(np.asarray(angle) / 2)
    q[..., axis + 1] = np.sin(np.asarray(angle) / 2)
    return q


def euler_to_dcm(angles, seq: str = "323"):
    """DCM of intrinsic Euler angles: ``R_a(angles[0]) @ R_b(angles[1]) @ R_c(angles[2])`` for ``seq = "abc"``.

    For ``seq = "313"`` and angles ``(psi, theta, sigma)`` this is seed 004 eq. 26, ``R = D C B``.
    Shapes ``(..., 3) -> (..., 3, 3)``.
    """
    i, j, k = _check_seq(seq)
    a = _check(angles, "angles", (3,))
    return axis_rotation(i + 1, a[..., 0]) @ axis_rotation(j + 1, a[..., 1]) @ axis_rotation(k + 1, a[..., 2])


def euler_to_quat(angles, seq: str = "323"):
    """Quaternion of intrinsic Euler angles, ``q_a ⊗ q_b ⊗ q_c`` (``w >= 0``); ``(..., 3) -> (..., 4)``."""
    i, j, k = _check_seq(seq)
    a = _check(angles, "angles", (3,))
    q = _qmul(_qmul(_axis_quat(i, a[..., 0]), _axis_quat(j, a[..., 1])), _axis_quat(k, a[..., 2]))
    return np.where(q[..., :1] < 0, -q, q)


def quat_to_euler(q, seq: str = "323", *, warn: bool = True):
    """Intrinsic Euler angles of a quaternion, ``(..., 4) -> (..., 3)``, by the direct method of
    Bernardes & Viollet (PLoS ONE 17(11), 2022) for any of the 12 sequences.

    Ranges: first and third angle in ``[-pi, pi]``; middle angle in ``[0, pi]`` for symmetric
    sequences and ``[-pi/2, pi/2]`` for asymmetric ones. Near gimbal lock (the middle angle within
    :data:`GIMBAL_LOCK_TOL` of its singular value) a :class:`GimbalLockWarning` is issued (unless
    ``warn=False``): the outer angles are then not unique. At the singularity itself the third angle is
    set to zero and the first takes the whole rotation. The angles always reproduce the rotation to
    rounding; never NaN.
    """
    ii, jj, kk = _check_seq(seq)
    q = _unit_quat(q)
    # An intrinsic sequence (i, j, k) with angles (a, b, c) is the extrinsic sequence (k, j, i) with
    # angles (c, b, a): run the extrinsic algorithm on the reversed sequence and swap back at the end.
    i, j, k = kk, jj, ii
    proper = i == k
    if proper:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2  # +1 for an even permutation of (0, 1, 2), -1 for odd
    w, qi, qj, qk = q[..., 0], q[..., 1 + i], q[..., 1 + j], q[..., 1 + k] * sign
    if proper:
        a, b, c, d = w, qi, qj, qk
    else:
        a, b, c, d = w - qj, qi + qk, qj + w, qk - qi
    theta2 = 2 * np.arctan2(np.hypot(c, d), np.hypot(a, b))  # in [0, pi]
    half_sum = np.arctan2(b, a)
    half_diff = np.arctan2(-d, c)
    # At the singularity only the sum (middle angle 0) or the difference (middle angle pi) of the
    # outer angles is defined: put it all in the first angle. Within a few ulps of it, doing so moves
    # the rotation by less than the rounding of q; further away the general formula is kept, because it
    # reproduces the rotation to rounding (the outer angles are then ill-conditioned, but finite).
    lock0 = theta2 <= _EXACT_LOCK
    lockpi = theta2 >= np.pi - _EXACT_LOCK
    theta1 = np.where(lock0 | lockpi, 0.0, half_sum + half_diff)
    theta3 = np.where(lock0, 2 * half_sum, np.where(lockpi, -2 * half_diff, half_sum - half_diff))
    locked = (theta2 <= GIMBAL_LOCK_TOL) | (theta2 >= np.pi - GIMBAL_LOCK_TOL)
    theta1 = _wrap(theta1)
    theta3 = _wrap(theta3)
    if not proper:
        theta3 = theta3 * sign
        theta2 = theta2 - np.pi / 2
    if warn and np.any(locked):
        warnings.warn(f"gimbal lock in Euler sequence {seq}: the middle angle is within {GIMBAL_LOCK_TOL:g} rad "
                      "of its singular value, so the first and third angles are not unique (at the "
                      "singularity the third angle is set to zero)", GimbalLockWarning, stacklevel=2)
    return np.stack([theta3, theta2, theta1], axis=-1)


def _wrap(a):
    """Wrap angles to [-pi, pi]."""
    return np.where(a > np.pi, a - 2 * np.pi, np.where(a < -np.pi, a + 2 * np.pi, a))


def dcm_to_euler(R, seq: str = "323", *, warn: bool = True):
    """Intrinsic Euler angles of a rotation matrix; see :func:`quat_to_euler` for ranges and gimbal lock."""
    return quat_to_euler(dcm_to_quat(R), seq, warn=warn)


# --------------------------------------------------------------------------------------------
# rotation vector, Gibbs vector, modified Rodrigues parameters (seed 000 §1.4-1.5, seed 004 eq. 21, 170)
# --------------------------------------------------------------------------------------------
def rotvec_to_quat(phi):
    """Quaternion of a rotation vector (the exponential map exp_S3 of seed 004 eq. 170).

    ``q = (cos(|phi|/2), sin(|phi|/2) phi/|phi|)``; series branch for small angles. ``(..., 3) -> (..., 4)``.
    """
    phi = _check(phi, "phi", (3,))
    angle = _norm(phi)
    return np.concatenate([np.cos(angle / 2)[..., None], (0.5 * _sinc(angle / 2))[..., None] * phi], axis=-1)


def quat_to_rotvec(q):
    """Rotation vector (angle in [0, pi]) of a quaternion, the inverse of :func:`rotvec_to_quat`."""
    q = _unit_quat(q)
    q = np.where(q[..., :1] < 0, -q, q)
    n = _norm(q[..., 1:])
    w = q[..., 0]
    tiny = n < 1e-300
    # angle/|v| = 2 atan2(n, w)/n; atan2 is accurate for small n, so only n == 0 needs a limit
    scale = np.where(tiny, 2 / np.maximum(w, 0.5), 2 * np.arctan2(n, w) / _safe(n, tiny))
    return scale[..., None] * q[..., 1:]


def rotvec_to_dcm(phi):
    """Rodrigues' formula ``exp([phi x])`` (seed 004 eq. 21, seed 000 §1.5.1), ``(..., 3) -> (..., 3, 3)``."""
    phi = _check(phi, "phi", (3,))
    angle = _norm(phi)[..., None, None]
    P = skew(phi)
    return np.eye(3) + _sinc(angle) * P + _one_minus_cos_over_x2(angle) * (P @ P)


def dcm_to_rotvec(R):
    """Rotation vector of a rotation matrix (angle in [0, pi])."""
    return quat_to_rotvec(dcm_to_quat(R))


def gibbs_to_quat(g):
    """Quaternion of a Gibbs (Rodrigues) vector ``g = tan(angle/2) axis`` (seed 000 §1.4): ``(1, g)/sqrt(1+|g|^2)``."""
    g = _check(g, "g", (3,))
    q = np.concatenate([np.ones(g.shape[:-1] + (1,)), g], axis=-1)
    return q / _norm(q)[..., None]


def quat_to_gibbs(q, *, max_angle: float = np.pi - 1e-6):
    """Gibbs vector ``v/w`` of a quaternion; singular at a 180° rotation (ValueError beyond ``max_angle``)."""
    q = _unit_quat(q)
    w = np.abs(q[..., 0])
    if np.any(w <= np.cos(max_angle / 2)):
        raise ValueError("q: the Gibbs vector is singular at a 180° rotation (tan(angle/2) -> inf)")
    return q[..., 1:] / q[..., :1]


def mrp_to_quat(s):
    """Quaternion of modified Rodrigues parameters ``s = tan(angle/4) axis``: ``((1-|s|^2), 2 s)/(1+|s|^2)``."""
    s = _check(s, "s", (3,))
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    return np.concatenate([1 - s2, 2 * s], axis=-1) / (1 + s2)


def quat_to_mrp(q, *, shadow: bool = False):
    """Modified Rodrigues parameters ``v/(1+w)`` of a quaternion.

    With ``shadow=False`` (default) the short set ``|s| <= 1`` is returned (from ``w >= 0``); with
    ``shadow=True`` the shadow set ``-s/|s|^2`` (``|s| >= 1``, from ``-q``) — undefined at zero rotation.
    """
    q = _unit_quat(q)
    q = np.where(q[..., :1] < 0, -q, q)
    if shadow:
        if np.any(q[..., 0] >= 1 - 1e-15):
            raise ValueError("q: the shadow MRP set is singular at zero rotation")
        q = -q
    return q[..., 1:] / (1 + q[..., :1])


def mrp_shadow(s):
    """The shadow MRP set ``-s/|s|^2`` (the same rotation); ValueError for ``s = 0``."""
    s = _check(s, "s", (3,))
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    if np.any(s2 == 0):
        raise ValueError("s: the shadow set of s = 0 is at infinity")
    return -s / s2


# --------------------------------------------------------------------------------------------
# normalisation (seed 000 §1.7) and attitude distance
# --------------------------------------------------------------------------------------------
def orthonormalize_dcm(R, method: str = "bjorck", *, tol: float = 10 * EPS, max_iter: int = 60):
    """Nearest orthogonal matrix (the orthogonal polar factor) of ``R``, shape ``(..., 3, 3)``.

    ``method="bjorck"``: the Björck-Bowie iteration ``X <- 1.5 X - 0.5 X X^T X`` (seed 000 §1.7.1),
    run until ``|X^T X - I| <= tol``; it converges for singular values in ``(0, sqrt(3))``.
    ``method="svd"``: ``U V^T`` from the singular value decomposition. Both give the same matrix.
    """
    X = _check(R, "R", (3, 3))
    if method == "svd":
        U, _, Vt = np.linalg.svd(X)
        return U @ Vt
    if method != "bjorck":
        raise ValueError(f"method: expected 'bjorck' or 'svd', got {method!r}")
    sv = np.linalg.svd(X, compute_uv=False)
    if np.any(sv <= 1e-12) or np.any(sv >= np.sqrt(3)):
        raise ValueError("R: the Björck-Bowie iteration needs singular values in (0, sqrt(3)); use method='svd'")
    eye = np.eye(3)
    for _ in range(max_iter):
        XtX = np.swapaxes(X, -1, -2) @ X
        if np.all(np.abs(XtX - eye) <= tol):
            return X
        X = 1.5 * X - 0.5 * X @ XtX
    raise ValueError(f"R: the Björck-Bowie iteration did not converge in {max_iter} iterations")


def frame_with_z(z) -> np.ndarray:
    """A proper orthonormal frame (columns) whose third axis is the unit vector ``z``."""
    helper = np.eye(3)[np.argmin(np.abs(z))]
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def attitude_error(qa, qb):
    """Geodesic angle [rad] between two attitudes, in ``[0, pi]``; the same for ``q`` and ``-q``.

    Computed as ``2 atan2(|vec(qa* ⊗ qb)|, |w(qa* ⊗ qb)|)``, accurate for tiny angles (no arccos).
    Shapes ``(..., 4)`` broadcast.
    """
    qa = _unit_quat(qa, "qa")
    qb = _unit_quat(qb, "qb")
    d = _qmul(qa * np.array([1.0, -1.0, -1.0, -1.0]), qb)
    return 2 * np.arctan2(_norm(d[..., 1:]), np.abs(d[..., 0]))


# --------------------------------------------------------------------------------------------
# Lie-group maps (seed 004 §2.5)
# --------------------------------------------------------------------------------------------
def quat_exp(u):
    """``exp_S3(u) = (cos|u/2|, sin|u/2| u/|u|)`` (seed 004 eq. 170): the unit quaternion of rotation vector u."""
    return rotvec_to_quat(u)


def quat_log(q):
    """Inverse of :func:`quat_exp`: the rotation vector (angle in [0, pi]) of ``q``."""
    return quat_to_rotvec(q)


def dexp(u):
    """``dexp_u`` on so(3) as a matrix, ``(..., 3) -> (..., 3, 3)``.

    ``dexp_u = I + (1-cos|u|)/|u|^2 [u x] + (|u| - sin|u|)/|u|^3 [u x]^2``, so that
    ``d/dt exp(u) = [(dexp_u u')x] exp(u)``; and ``dexp_{-u}`` gives the body rate of ``R0 exp(u(t))``:
    ``omega = dexp_{-u} u'``.
    """
    u = _check(u, "u", (3,))
    angle = _norm(u)[..., None, None]
    U = skew(u)
    return np.eye(3) + _one_minus_cos_over_x2(angle) * U + _x_minus_sin_over_x3(angle) * (U @ U)


def dexp_inv(u):
    """Inverse of :func:`dexp`: ``I - 1/2 [u x] + (1 - (|u|/2) cot(|u|/2))/|u|^2 [u x]^2``.

    Seed 004 eq. 167 is ``dexp_inv(-u) @ omega``: the rate ``u'`` of the incremental rotation vector of
    ``R(t) = R_n exp(u(t))`` with body rate ``omega`` (eq. 166). Valid for ``|u| < 2 pi``.
    """
    u = _check(u, "u", (3,))
    angle = _norm(u)
    if np.any(angle >= 2 * np.pi - 1e-9):
        raise ValueError("u: dexp^-1 is singular at |u| = 2 pi")
    U = skew(u)
    return np.eye(3) - 0.5 * U + _dexp_inv_coefficient(angle)[..., None, None] * (U @ U)


# --------------------------------------------------------------------------------------------
# kinematic rates: d/dt of each parametrization given the body rate omega (body components)
# --------------------------------------------------------------------------------------------
def quat_rate(q, omega):
    """``q' = 1/2 q ⊗ (0, omega)`` (seed 000 §1.3.5; seed 004 eq. 162 ``p' = 1/2 G^T omega'``)."""
    q = _check(q, "q", (4,))
    omega = _check(omega, "omega", (3,))
    w0 = np.concatenate([np.zeros(omega.shape[:-1] + (1,)), omega], axis=-1)
    return 0.5 * _qmul(q, w0)


def dcm_rate(R, omega):
    """``R' = R [omega x]`` (seed 000 eq. 1.7 for the body->world matrix; seed 004 eq. 131)."""
    R = _check(R, "R", (3, 3))
    return R @ skew(omega)


def _euler_columns(angles, seq):
    """Columns of the matrix J with ``omega = J @ angle_rates`` for intrinsic Euler angles."""
    i, j, k = _check_seq(seq)
    a = _check(angles, "angles", (3,))
    Rj = axis_rotation(j + 1, a[..., 1])
    Rk = axis_rotation(k + 1, a[..., 2])
    RkT = np.swapaxes(Rk, -1, -2)
    # omega = Rk^T Rj^T e_i a' + Rk^T e_j b' + e_k c'
    col_a = (RkT @ np.swapaxes(Rj, -1, -2))[..., :, i]
    col_b = RkT[..., :, j]
    col_c = np.broadcast_to(np.eye(3)[k], col_a.shape)
    return col_a, col_b, col_c


def euler_rate_matrix(angles, seq: str = "323"):
    """Matrix J with ``omega_body = J @ [a', b', c']`` for intrinsic Euler angles, ``(..., 3) -> (..., 3, 3)``.

    For ``"323"`` this is seed 001's ``velocidade_angular``. ``det J = -sin(b)`` (symmetric sequences)
    or ``±cos(b)`` (asymmetric): singular when the first and third axes coincide.
    """
    return np.stack(_euler_columns(angles, seq), axis=-1)


def euler_rates_to_omega(angles, rates, seq: str = "323"):
    """Body rate from Euler angles and their rates (seed 001 ``velocidade_angular``), ``(..., 3)``."""
    rates = _check(rates, "rates", (3,))
    return (euler_rate_matrix(angles, seq) @ rates[..., None])[..., 0]


def omega_to_euler_rates(angles, omega, seq: str = "323", *, tol: float = 1e-12):
    """Euler-angle rates from the body rate (seed 001 ``cinversa_euler``; seed 000 §1.2.2).

    Raises :class:`EulerSingularityError` where ``|det J| < tol`` (the first and third axes coincide:
    ``sin b = 0`` for symmetric, ``cos b = 0`` for asymmetric sequences) instead of dividing by zero.
    """
    angles = _check(angles, "angles", (3,))
    omega = _check(omega, "omega", (3,))
    c1, c2, c3 = _euler_columns(angles, seq)
    det = np.sum(c1 * np.cross(c2, c3), axis=-1)
    bad = np.abs(det) < tol
    if np.any(bad):
        b = float(np.broadcast_to(angles[..., 1], bad.shape)[bad].flat[0])
        raise EulerSingularityError(
            f"Euler sequence {seq} is singular at middle angle {b:.6g} rad "
            f"({np.degrees(b):.6g} deg): the first and third rotation axes coincide",
            middle_angle=b, sequence=seq)
    # rows of J^-1 are (c2 x c3, c3 x c1, c1 x c2) / det
    inv_rows = np.stack([np.cross(c2, c3), np.cross(c3, c1), np.cross(c1, c2)], axis=-2) / det[..., None, None]
    return (inv_rows @ omega[..., None])[..., 0]


def gibbs_rate(g, omega):
    """``g' = 1/2 (I + [g x] + g g^T) omega`` for the Gibbs vector of our body->world quaternion.

    Seed 000 §1.4.2 prints the matrix ``I + g g^T - [g x]``: that is the rate of the *inverse*
    rotation's Gibbs vector, inconsistent with its own §1.4.1 DCM; see ``tests/test_rotations.py``.
    """
    g = _check(g, "g", (3,))
    omega = _check(omega, "omega", (3,))
    return 0.5 * (omega + np.cross(g, omega) + g * np.sum(g * omega, axis=-1, keepdims=True))


def mrp_rate(s, omega):
    """``s' = 1/4 ((1 - |s|^2) I + 2 [s x] + 2 s s^T) omega`` (Schaub & Junkins)."""
    s = _check(s, "s", (3,))
    omega = _check(omega, "omega", (3,))
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    return 0.25 * ((1 - s2) * omega + 2 * np.cross(s, omega) + 2 * s * np.sum(s * omega, axis=-1, keepdims=True))


def rotvec_rate(phi, omega):
    """Rotation-vector kinematics with the non-commutativity term (seed 000 §1.5.2, Bortz):

    ``phi' = omega + 1/2 phi x omega + (1/|phi|^2)(1 - |phi| sin|phi| / (2(1 - cos|phi|))) phi x (phi x omega)``,
    i.e. ``dexp_inv(-phi) @ omega`` (seed 004 eq. 167); series branch for small ``|phi|``.
    """
    phi = _check(phi, "phi", (3,))
    omega = _check(omega, "omega", (3,))
    angle = _norm(phi)
    if np.any(angle >= 2 * np.pi - 1e-9):
        raise ValueError("phi: the rotation-vector rate is singular at |phi| = 2 pi")
    c = _dexp_inv_coefficient(angle)[..., None]
    pxw = np.cross(phi, omega)
    return omega + 0.5 * pxw + c * np.cross(phi, pxw)
