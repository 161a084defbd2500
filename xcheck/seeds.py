"""The seeds' own conventions, converted at the boundary to xcheck's (see :mod:`xcheck.rotations`).

Seed 000 (lecture notes): ``D_V^I`` maps reference-frame (I) components to body (V) components, i.e. the
transpose of our ``R``; its quaternion ``q_V^I`` obeys ``q' = 1/2 q ⊗ (0, omega)`` and is therefore our
body->world quaternion unchanged (``D_V^I = quat_to_dcm(q).T``, §1.3.4).

Seed 001 (thesis, appendix A): Euler angles ``[psi, theta, phi]`` of the Z-Y-Z sequence with
``R = Rz(psi) Ry(theta) Rz(phi)`` body->world: our ``"323"`` unchanged; its quaternions are scalar first.

Seed 002 (report): quaternions scalar LAST ``[q1, q2, q3, q4]`` and the attitude matrix
``R_bi = (q4^2 - q.q) I + 2 q q^T - 2 q4 [q x]`` (eq. 1.10) mapping inertial to body components.

Seed 004 (thesis): Euler parameters ``p = [e0, e1, e2, e3]`` scalar first, ``R = E G^T`` (eq. 111) maps
body (local) to global components: our convention unchanged. Its eq. 179, said to be the 3-1-3 angles of
eq. 22-26, is in fact the 3-2-1 formula (yaw psi, pitch theta, roll sigma); the printed eq. 178 is the
*conjugate* of eq. 179's value (up to sign): the inverse rotation.
"""

from __future__ import annotations

import numpy as np

from .rotations import _check, skew

__all__ = [
    "seed002_quat_to_quat",
    "quat_to_seed002_quat",
    "seed002_attitude_matrix",
    "seed002_matrix_to_dcm",
    "seed004_eq179",
    "SEED004_P0_PRINTED",
    "SEED002_BODY",
    "SEED002_V4B_PRINTED",
    "SEED002_REFERENCE",
    "SEED002_TRIAD",
    "SEED002_Q_METHOD",
    "SEED002_WEIGHT_SEARCH",
]

#: Seed 004 eq. 178, the initial Euler parameters the thesis integrated (as printed, 4 digits).
SEED004_P0_PRINTED = np.array([-0.4583, -0.6558, 0.5997, 0.0182])


def seed002_quat_to_quat(q_last):
    """Seed 002's scalar-last quaternion ``[q1, q2, q3, q4]`` -> ours ``[w, x, y, z] = [q4, q1, q2, q3]``.

    Seed 002's attitude matrix of ``q_last`` (eq. 1.10) is ``quat_to_dcm(ours).T``.
    """
    q = _check(q_last, "q_last", (4,))
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def quat_to_seed002_quat(q):
    """Ours ``[w, x, y, z]`` -> seed 002's scalar-last ``[x, y, z, w]``."""
    q = _check(q, "q", (4,))
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def seed002_attitude_matrix(q_last):
    """Seed 002 eq. 1.10 as printed: ``(q4^2 - q.q) I + 2 q q^T - 2 q4 [q x]`` (inertial -> body)."""
    q = _check(q_last, "q_last", (4,))
    v, q4 = q[..., :3], q[..., 3]
    return ((q4**2 - np.sum(v * v, axis=-1))[..., None, None] * np.eye(3)
            + 2 * v[..., :, None] * v[..., None, :] - 2 * q4[..., None, None] * skew(v))


def seed002_matrix_to_dcm(R_bi):
    """Seed 002's inertial->body matrix ``R_bi`` -> our body->world ``R`` (its transpose)."""
    return np.swapaxes(_check(R_bi, "R_bi", (3, 3)), -1, -2)


def seed004_eq179(sigma, theta, psi):
    """Seed 004 eq. 179 exactly as printed (angles in radians), scalar first.

    It equals ``euler_to_quat([psi, theta, sigma], "321")`` — yaw ``psi``, pitch ``theta``, roll ``sigma``
    — not the 3-1-3 sequence of eq. 22-26. With eq. 180's angles it gives ``+0.4583`` first, where eq. 178
    prints ``-0.4583``: eq. 178 is the conjugate (inverse rotation) of eq. 179 up to the sign of ``q``.
    """
    s, t, p = np.asarray(sigma, float) / 2, np.asarray(theta, float) / 2, np.asarray(psi, float) / 2
    cs, ss, ct, st, cp, sp = np.cos(s), np.sin(s), np.cos(t), np.sin(t), np.cos(p), np.sin(p)
    return np.stack([cs * ct * cp + ss * st * sp,
                     -cs * st * sp + ss * ct * cp,
                     cs * st * cp + ss * ct * sp,
                     cs * ct * sp - ss * st * cp], axis=-1)



# --------------------------------------------------------------------------------------------------------
# Seed 002's data and printed results (eq. 0.1-0.2, 1.6-1.21, 2.7-2.14 and the MATLAB listing §3-4)
# --------------------------------------------------------------------------------------------------------
#: The body-frame observations v1b..v4b as the MATLAB listing types them (§4.1 line 9: v4b z = -0.2884).
SEED002_BODY = np.array([[0.8273, 0.5541, -0.0920],
                         [-0.8285, 0.5522, -0.0955],
                         [0.2155, 0.5522, 0.8022],
                         [0.5570, -0.7442, -0.2884]])
#: The problem statement's v4b (eq. 0.1), which prints z = -0.2882.
SEED002_V4B_PRINTED = np.array([0.5570, -0.7442, -0.2882])
#: The reference (inertial) directions v1i..v4i (eq. 0.2).
SEED002_REFERENCE = np.array([[-0.1517, -0.9669, 0.2050],
                              [-0.8393, 0.4494, -0.3044],
                              [-0.0886, -0.5856, -0.8000],
                              [0.8814, -0.0303, 0.5202]])
#: TRIAD with observations (1, k), k = 2, 3, 4: R_bi (inertial -> body), the quaternion scalar LAST as
#: printed (the listing's q4 = +1/2 sqrt(1 + tr R) > 0), the loss with w = 1/2 each (eq. 1.6-1.21, §3).
SEED002_TRIAD = {
    2: dict(R=[[0.4156, -0.8551, 0.3100], [-0.8339, -0.4943, -0.2455], [0.3631, -0.1566, -0.9185]],
            q=[-0.8409, 0.5022, -0.2001, 0.0264], J=1.8298e-7),
    3: dict(R=[[0.4167, -0.8563, 0.3051], [-0.8370, -0.4924, -0.2387], [0.3546, -0.1559, -0.9219]],
            q=[-0.8413, 0.5032, -0.1961, 0.0246], J=1.1146e-5),
    4: dict(R=[[0.4279, -0.8736, 0.2317], [-0.8750, -0.4646, -0.1359], [0.2263, -0.1446, -0.9633]],
            q=[0.8449, -0.5174, 0.1355, 0.0026], J=0.0014),
}
#: The q-method with w = 1/4 each (eq. 2.7-2.10): quaternion scalar LAST, R_bi, loss.
SEED002_Q_METHOD = dict(w=[0.25, 0.25, 0.25, 0.25], q=[-0.8498, 0.4975, -0.1741, 0.0060],
                        R=[[0.4443, -0.8477, 0.2899], [-0.8435, -0.5048, -0.1834], [0.3018, -0.1630, -0.9393]],
                        J=0.0019)
#: The report's weight search (eq. 2.11-2.14): weights and the loss it printed for them.
SEED002_WEIGHT_SEARCH = dict(w=[0.97, 0.01, 0.01, 0.01], J=8.9985e-5, w_one=[1.0, 0.0, 0.0, 0.0], J_one=5.0845e-32)
