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

