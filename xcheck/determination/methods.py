"""Static attitude determination (seed 002): TRIAD, Davenport's q-method, Shuster's QUEST and Markley's SVD
method, each on a stack of problems in one call.

The problem (Wahba's): find the attitude matrix ``A`` (inertial -> body) minimising the loss of seed 002
eq. 1.12, ``J = 1/2 sum_k w_k |b_k - A r_k|^2``, where ``b_k`` are directions observed in the body frame
and ``r_k`` the same directions modelled in the reference (inertial) frame.

Conventions at this boundary (the rest of xcheck's are in :mod:`xcheck.rotations`):

* ``b``, ``r``: shape ``(..., N, 3)``, any length (normalised here, as the seed's listing does); ``w``:
  ``(N,)`` or ``(..., N)``, positive (default ``1/N`` each, the seed's choice).
* The result's ``q`` is ours, ``[w, x, y, z]`` body -> world, and ``A = quat_to_dcm(q).T`` is the seed's
  ``R_bi`` (Wahba's attitude matrix). Seed 002's scalar-last quaternion ``[q1, q2, q3, q4]`` with the
  attitude matrix of its eq. 1.10 is Shuster's, and re-ordered scalar first it *is* our ``q``
  (:func:`xcheck.seeds.seed002_quat_to_quat`): the eigenvector of ``K`` (eq. 2.3) is read that way.

Refused with :class:`DeterminationError` (a ``ValueError`` naming the argument and the problem's index):
shapes that do not match, fewer than two observations, non-finite or zero-length vectors, negative or zero
weights, and observations that do not fix an attitude — every positively weighted direction parallel (or
antiparallel) to one line in either frame. That includes seed 002's ``w = (1, 0, 0, 0)``: one direction
fixes the attitude only up to a rotation about it, so any such rotation fits with ``J = 0`` and no attitude
is returned. *Near*-degenerate problems (directions within ``near_angle_deg`` of each other, or the
equivalent eigenvalue gap) are solved and flagged in ``near_degenerate``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._jit import njit
from ..base.errors import UserError
from ..rotations import _check, dcm_to_quat, quat_to_dcm, skew

__all__ = [
    "DeterminationError",
    "Estimate",
    "METHODS",
    "NEAR_ANGLE_DEG",
    "attitude_profile",
    "davenport_k",
    "loss",
    "triad",
    "q_method",
    "quest",
    "svd_method",
    "determine",
]

#: Directions closer than this [deg] (or the equivalent eigenvalue gap) flag a solution as near-degenerate:
#: the error about the common axis is then amplified more than 57-fold (1/sin 1°).
NEAR_ANGLE_DEG = 1.0

#: Directions with |u x v| below this are parallel: the attitude is undetermined and refused.
PARALLEL_SIN = 1e-10


class DeterminationError(UserError):
    """Input that does not determine an attitude; the message names the argument and the problem."""


@dataclass(frozen=True, eq=False)
class Estimate:
    """The attitudes of a stack of problems (leading shape ``...``, ``()`` for one problem).

    ``q`` ``(..., 4)`` ours (body -> world, ``q[0] >= 0``); ``A`` ``(..., 3, 3)`` inertial -> body (the seed's
    ``R_bi``); ``loss`` ``(...)`` seed 002 eq. 1.12 with the weights used; ``lam``, ``gap``: the largest
    eigenvalue of ``K`` (eq. 2.6) and its distance to the second (NaN for TRIAD, which uses no ``K``);
    ``condition`` ``>= 1``: 1/sin of the angle between TRIAD's two directions (the larger of the body's and the
    reference's), and for the other methods ``lam / sqrt(lam^2 - max(lam2, 0)^2)``, which is the same number
    for two exact, equally weighted directions; ``near_degenerate``: ``condition > 1/sin(near_angle_deg)``.
    """

    method: str
    q: np.ndarray
    A: np.ndarray
    loss: np.ndarray
    lam: np.ndarray
    gap: np.ndarray
    condition: np.ndarray
    near_degenerate: np.ndarray

    @property
    def R(self) -> np.ndarray:
        """Our body -> world matrix, ``A.T``."""
        return np.swapaxes(self.A, -1, -2)

    @property
    def warning(self) -> str | None:
        """A sentence when any problem is near-degenerate, else None."""
        flags = np.asarray(self.near_degenerate)
        n = int(flags.sum())
        if not n:
            return None
        total = flags.size
        which = "the problem is" if total == 1 else f"{n} of {total} problems are"
        worst = float(np.max(self.condition))
        return (f"{self.method}: {which} near-degenerate (directions within {NEAR_ANGLE_DEG:g}° of each other or an "
                f"equivalent eigenvalue gap; error amplification up to {worst:.3g}): the attitude about the common "
                "direction is poorly determined")


# --------------------------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------------------------
def _array(x, name: str) -> np.ndarray:
    """``x`` as a finite float array of shape ``(..., 3)`` (rotations' check, as a DeterminationError)."""
    if np.iscomplexobj(x):
        raise DeterminationError(f"{name}: complex values; expected real vectors")
    try:
        return _check(x, name, (3,))
    except DeterminationError:
        raise
    except ValueError as exc:
        raise DeterminationError(str(exc)) from None


def _where(index) -> str:
    index = tuple(int(i) for i in np.atleast_1d(index))
    return f"[{', '.join(map(str, index))}]"


def _unit(v: np.ndarray, name: str) -> np.ndarray:
    """``v / |v|`` of any length (scaled by its largest component first: 1e±200 neither overflows nor
    underflows); a zero vector is refused."""
    m = np.max(np.abs(v), axis=-1)
    bad = ~(m > 0)
    if np.any(bad):
        raise DeterminationError(f"{name}{_where(np.argwhere(bad)[0])}: a zero-length vector has no direction")
    v = v / _rescale(m)[..., None]
    return v / np.sqrt(np.sum(v * v, axis=-1))[..., None]


#: Magnitudes within which the methods' arithmetic neither overflows nor underflows: outside, a vector (whose
#: norm squares it) or a set of weights (QUEST's polynomial raises the eigenvalue, their sum, to the sixth) is
#: divided by its largest entry first; inside, nothing changes, to the bit.
_SAFE_VECTOR, _SAFE_WEIGHT = (1e-100, 1e100), (1e-30, 1e30)


def _rescale(m, safe=_SAFE_VECTOR):
    """The divisor of entries whose largest magnitude is ``m``: ``m`` outside ``safe``, else 1 (and 1 for 0)."""
    return np.where(((m >= safe[0]) & (m <= safe[1])) | (m == 0), 1.0, m)


def _vectors(b, r):
    b = _array(b, "b")
    r = _array(r, "r")
    if b.ndim < 2 or b.shape != r.shape:
        raise DeterminationError(f"b and r: expected the same shape (..., N, 3), N observations each, got b {b.shape} "
                                 f"and r {r.shape}")
    if b.shape[-2] < 2:
        raise DeterminationError(f"b, r: {b.shape[-2]} observation(s); an attitude needs at least two non-parallel "
                                 "directions (one fixes it only up to a rotation about itself)")
    return _unit(b, "b"), _unit(r, "r")


def _weights(w, shape):
    """``(w / scale, scale)``: ``w`` broadcast to ``shape`` (``(..., N)``), every entry positive, relative to its
    largest (``scale``, ``(...,)``): only the weights' ratios set an attitude, and relative weights cannot
    overflow or underflow the methods' arithmetic (1e±60 and beyond); ``lam``, the gap and the loss are scaled
    back. The default 1/N each. A weight so small beside another that it is 0 relative to it does not count."""
    n = shape[-1]
    if w is None:
        return np.full(shape, 1.0 / n), np.ones(shape[:-1])
    if np.iscomplexobj(w):
        raise DeterminationError("w: complex values; expected real weights")
    try:
        w = np.asarray(w, dtype=float)
    except (TypeError, ValueError):
        raise DeterminationError(f"w: expected {n} positive weights, got {type(w).__name__}") from None
    if w.ndim == 0 or w.shape[-1] != n:
        raise DeterminationError(f"w: expected shape (N,) or (..., N) with N = {n} observations, got {w.shape}")
    try:
        w = np.broadcast_to(w, shape)
    except ValueError:
        raise DeterminationError(f"w: shape {w.shape} does not match the observations' {shape}") from None
    if not np.all(np.isfinite(w)):
        raise DeterminationError("w: contains non-finite values (NaN or inf)")
    if np.any(w < 0):
        raise DeterminationError(f"w{_where(np.argwhere(w < 0)[0])}: a weight must be positive (it is 1/σ² of its "
                                 f"sensor), got {w[tuple(np.argwhere(w < 0)[0])]:g}")
    given = w
    largest = w.max(axis=-1)
    w = w / np.where(largest > 0, largest, 1.0)[..., None]  # relative: what counts beside what
    positive = (w > 0).sum(axis=-1)
    if np.any(positive < 2):
        at = np.argwhere(positive < 2)[0]
        row = given[tuple(at)]
        k = int(np.argmax(row))
        where = f" in problem {_where(at)}" if len(shape) > 1 else ""
        raise DeterminationError(
            f"w = {np.array2string(row, separator=', ')}{where}: only observation {k} counts, and one direction "
            f"fixes the attitude only up to a rotation about it: any rotation about b[{k}] fits it exactly (J = 0), "
            "so there is no attitude to return (seed 002's w = (1, 0, 0, 0) case). Give two non-parallel "
            "directions positive weights")
    if np.any(given == 0):
        raise DeterminationError(f"w{_where(np.argwhere(given == 0)[0])} = 0: an observation with zero weight plays "
                                 "no part; leave it out")
    if np.any(w == 0):
        at = tuple(np.argwhere(w == 0)[0])
        raise DeterminationError(f"w{_where(at)} = {given[at]:g} is zero beside the largest weight of its problem "
                                 f"({largest[at[:-1]]:g}): that observation plays no part; leave it out")
    scale = _rescale(largest, _SAFE_WEIGHT)
    return given / scale[..., None], scale


def _check_spread(u: np.ndarray, name: str) -> None:
    """Refuse a problem whose directions ``u`` (..., N, 3) all lie on one line."""
    cross = np.cross(u[..., :1, :], u[..., 1:, :])
    spread = np.sqrt(np.sum(cross * cross, axis=-1)).max(axis=-1)
    if np.any(spread < PARALLEL_SIN):
        at = np.argwhere(spread < PARALLEL_SIN)[0]
        where = f" (problem {_where(at)})" if u.ndim > 2 else ""
        raise DeterminationError(f"{name}: every direction is parallel to {name}[0]{where}; the attitude is "
                                 f"undetermined: any rotation about {name}[0] fits. Give two non-parallel directions")


def _observations(b, r, w):
    """Unit directions, relative weights and their scale (see :func:`_weights`)."""
    b, r = _vectors(b, r)
    w, scale = _weights(w, b.shape[:-1])
    _check_spread(b, "b")
    _check_spread(r, "r")
    return b, r, w, scale


# --------------------------------------------------------------------------------------------------------
# the pieces every method shares
# --------------------------------------------------------------------------------------------------------
def attitude_profile(b, r, w):
    """``B = sum_k w_k b_k r_k^T`` (seed 002 eq. 2.4), ``(..., N, 3)`` -> ``(..., 3, 3)``."""
    return np.einsum("...k,...ki,...kj->...ij", w, b, r)


def _szs(B):
    """S, Z, sigma of seed 002 eq. 2.4."""
    S = B + np.swapaxes(B, -1, -2)
    Z = np.stack([B[..., 1, 2] - B[..., 2, 1], B[..., 2, 0] - B[..., 0, 2], B[..., 0, 1] - B[..., 1, 0]], axis=-1)
    sigma = np.trace(B, axis1=-2, axis2=-1)
    return S, Z, sigma


def davenport_k(B):
    """Davenport's ``K = [[S - sigma I, Z], [Z^T, sigma]]`` (seed 002 eq. 2.3), scalar-LAST like the seed."""
    S, Z, sigma = _szs(B)
    K = np.empty(B.shape[:-2] + (4, 4))
    K[..., :3, :3] = S - sigma[..., None, None] * np.eye(3)
    K[..., :3, 3] = Z
    K[..., 3, :3] = Z
    K[..., 3, 3] = sigma
    return K


def loss(A, b, r, w=None):
    """Seed 002 eq. 1.12: ``J = 1/2 sum_k w_k |b_k - A r_k|^2`` (directions normalised; ``w`` default 1/N)."""
    b, r = _vectors(b, r)
    w, scale = _weights(w, b.shape[:-1])
    try:
        A = _check(A, "A", (3, 3))
    except ValueError as exc:
        raise DeterminationError(str(exc)) from None
    return scale * _loss(A, b, r, w)


def _loss(A, b, r, w):
    d = b - np.einsum("...ij,...kj->...ki", A, r)
    return 0.5 * np.einsum("...k,...ki,...ki->...", w, d, d)


def _near_limit(near_angle_deg: float) -> float:
    if not (0 < near_angle_deg < 90):
        raise DeterminationError(f"near_angle_deg: expected an angle between 0 and 90 degrees, got {near_angle_deg!r}")
    return 1.0 / np.sin(np.radians(near_angle_deg))


def _condition(lam, lam2):
    lam2 = np.maximum(lam2, 0.0)
    return lam / np.sqrt(np.maximum(lam * lam - lam2 * lam2, np.finfo(float).tiny))


def _finish(method, q, b, r, w, scale, lam, lam2, near_angle_deg) -> Estimate:
    """The estimate of relative weights ``w`` (``lam``, ``lam2`` theirs), its loss and eigenvalues scaled back."""
    q = q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
    q = np.where(q[..., :1] < 0, -q, q)
    A = np.swapaxes(quat_to_dcm(q), -1, -2)
    condition = _condition(lam, lam2)
    return Estimate(method, q, A, scale * _loss(A, b, r, w), scale * lam, scale * (lam - lam2), condition,
                    condition > _near_limit(near_angle_deg))


# --------------------------------------------------------------------------------------------------------
# the methods
# --------------------------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _triad_kernel(b, r, w, q, A, J, sines, lengths):  # pragma: no cover - compiled
    """TRIAD on rows of ``b``, ``r`` (M, 2, 3) (any length), weights ``w`` (M, 2): writes ``q`` (M, 4) ours,
    ``A`` (M, 3, 3) inertial -> body, the loss ``J`` (M,), the sines of the angle between the two directions
    in each frame ``sines`` (M, 2) and the four lengths (M, 4). One pass, no temporaries."""
    Tb = np.empty((3, 3))
    Tr = np.empty((3, 3))
    for m in range(b.shape[0]):
        for f in range(2):
            u = b[m] if f == 0 else r[m]
            T = Tb if f == 0 else Tr
            n1 = np.sqrt(u[0, 0] ** 2 + u[0, 1] ** 2 + u[0, 2] ** 2)
            n2 = np.sqrt(u[1, 0] ** 2 + u[1, 1] ** 2 + u[1, 2] ** 2)
            lengths[m, 2 * f] = n1
            lengths[m, 2 * f + 1] = n2
            if n1 == 0.0 or n2 == 0.0:
                sines[m, f] = 0.0
                continue
            x1, y1, z1 = u[0, 0] / n1, u[0, 1] / n1, u[0, 2] / n1  # eq. 1.1: t1 = v1
            x2, y2, z2 = u[1, 0] / n2, u[1, 1] / n2, u[1, 2] / n2
            cx, cy, cz = y1 * z2 - z1 * y2, z1 * x2 - x1 * z2, x1 * y2 - y1 * x2
            s = np.sqrt(cx * cx + cy * cy + cz * cz)
            sines[m, f] = s
            if s == 0.0:
                continue
            cx, cy, cz = cx / s, cy / s, cz / s  # eq. 1.2: t2 = unit(v1 x v2)
            T[0, 0], T[1, 0], T[2, 0] = x1, y1, z1
            T[0, 1], T[1, 1], T[2, 1] = cx, cy, cz
            T[0, 2], T[1, 2], T[2, 2] = y1 * cz - z1 * cy, z1 * cx - x1 * cz, x1 * cy - y1 * cx  # t3 = t1 x t2
        if sines[m, 0] == 0.0 or sines[m, 1] == 0.0:
            continue
        for i in range(3):  # eq. 1.5: R_bi = R_bt R_it^T
            for j in range(3):
                A[m, i, j] = Tb[i, 0] * Tr[j, 0] + Tb[i, 1] * Tr[j, 1] + Tb[i, 2] * Tr[j, 2]
        a = A[m]
        # Shepperd on R = A^T (R[i, j] = a[j, i]): the largest of 4w^2, 4x^2, 4y^2, 4z^2 first
        tr = a[0, 0] + a[1, 1] + a[2, 2]
        if tr >= a[0, 0] and tr >= a[1, 1] and tr >= a[2, 2]:
            q0, q1, q2, q3 = 1 + tr, a[1, 2] - a[2, 1], a[2, 0] - a[0, 2], a[0, 1] - a[1, 0]
        elif a[0, 0] >= a[1, 1] and a[0, 0] >= a[2, 2]:
            q0, q1, q2, q3 = a[1, 2] - a[2, 1], 1 + 2 * a[0, 0] - tr, a[1, 0] + a[0, 1], a[2, 0] + a[0, 2]
        elif a[1, 1] >= a[2, 2]:
            q0, q1, q2, q3 = a[2, 0] - a[0, 2], a[1, 0] + a[0, 1], 1 + 2 * a[1, 1] - tr, a[2, 1] + a[1, 2]
        else:
            q0, q1, q2, q3 = a[0, 1] - a[1, 0], a[2, 0] + a[0, 2], a[2, 1] + a[1, 2], 1 + 2 * a[2, 2] - tr
        n = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        if q0 < 0:
            n = -n
        q[m, 0], q[m, 1], q[m, 2], q[m, 3] = q0 / n, q1 / n, q2 / n, q3 / n
        total = 0.0
        for k in range(2):  # eq. 1.12
            nb, nr = lengths[m, k], lengths[m, 2 + k]
            for i in range(3):
                d = b[m, k, i] / nb - (a[i, 0] * r[m, k, 0] + a[i, 1] * r[m, k, 1] + a[i, 2] * r[m, k, 2]) / nr
                total += w[m, k] * d * d
        J[m] = 0.5 * total


def triad(b1, b2, r1, r2, *, w=None, near_angle_deg: float = NEAR_ANGLE_DEG) -> Estimate:
    """TRIAD (seed 002 §1, eq. 1.1-1.5): the attitude that maps ``r1`` exactly onto ``b1`` (the better sensor)
    and puts ``r2`` in the plane of ``b1``, ``b2``. Each argument ``(..., 3)`` (broadcast); ``w`` (2,) or
    ``(..., 2)`` only weighs the reported loss (default 1/2 each, the seed's).

    The third triad vector is ``t1 x t2`` in both frames; eq. 1.3 prints ``t1b x t2i`` for the body frame, a
    misprint (the listing's ``triad.m`` computes ``t1_b x t2_b``). Compiled: one pass over the stack.
    """
    given = [(_array(v, n), n) for v, n in ((b1, "b1"), (b2, "b2"), (r1, "r1"), (r2, "r2"))]
    try:
        vs = np.broadcast_arrays(*(v for v, _ in given))
    except ValueError:
        raise DeterminationError("b1, b2, r1, r2: stacks that do not broadcast together ("
                                 f"{', '.join(f'{n} {v.shape}' for v, n in given)})") from None
    shape = vs[0].shape[:-1]
    # each by its largest component first: any length neither overflows nor underflows the kernel's norms
    vs = [v / _rescale(np.max(np.abs(v), axis=-1, keepdims=True)) for v in vs]
    b = np.ascontiguousarray(np.stack(vs[:2], axis=-2).reshape(-1, 2, 3))
    r = np.ascontiguousarray(np.stack(vs[2:], axis=-2).reshape(-1, 2, 3))
    w, scale = _weights(w, shape + (2,))
    w = np.ascontiguousarray(w.reshape(-1, 2))
    m = b.shape[0]
    q, A, J = np.empty((m, 4)), np.empty((m, 3, 3)), np.empty(m)
    sines, lengths = np.empty((m, 2)), np.empty((m, 4))
    _triad_kernel(b, r, w, q, A, J, sines, lengths)
    for k, name in enumerate(("b1", "b2", "r1", "r2")):
        if np.any(lengths[:, k] == 0):
            at = np.unravel_index(int(np.argmax(lengths[:, k] == 0)), shape)
            raise DeterminationError(f"{name}{_where(at) if shape else ''}: a zero-length vector has no direction")
    for f, (u, v) in enumerate((("b1", "b2"), ("r1", "r2"))):
        if np.any(sines[:, f] < PARALLEL_SIN):
            at = np.unravel_index(int(np.argmax(sines[:, f] < PARALLEL_SIN)), shape)
            where = f" (problem {_where(at)})" if shape else ""
            raise DeterminationError(f"{u}, {v}: parallel directions{where}; the attitude is undetermined: any "
                                     f"rotation about {u} fits. Give two non-parallel directions")
    condition = (1.0 / sines.min(axis=-1)).reshape(shape)
    nan = np.full(shape, np.nan)
    return Estimate("triad", q.reshape(shape + (4,)), A.reshape(shape + (3, 3)), scale * J.reshape(shape), nan, nan,
                    condition, condition > _near_limit(near_angle_deg))


def q_method(b, r, w=None, *, near_angle_deg: float = NEAR_ANGLE_DEG) -> Estimate:
    """Davenport's q-method (seed 002 §2, eq. 2.1-2.6): the eigenvector of ``K`` for its largest eigenvalue,
    by a symmetric eigensolver (LAPACK, batched)."""
    b, r, w, scale = _observations(b, r, w)
    lams, vecs = np.linalg.eigh(davenport_k(attitude_profile(b, r, w)))
    v = vecs[..., :, 3]  # scalar last [q1, q2, q3, q4], the attitude matrix of eq. 1.10
    q = np.concatenate([v[..., 3:], v[..., :3]], axis=-1)
    return _finish("q-method", q, b, r, w, scale, lams[..., 3], lams[..., 2], near_angle_deg)


#: The reference frame turned 180° about x, y, z (Shuster & Oh's method of sequential rotations): the
#: diagonal of T_i, and the matrix of ``q -> [0, e_i] ⊗ q`` that turns the solution back (``R = T_i R'``).
_TURNS = tuple(np.where(np.eye(3)[i] > 0, 1.0, -1.0) for i in range(3))
_UNTURN = tuple(np.block([[np.zeros((1, 1)), -np.eye(3)[i][None, :]], [np.eye(3)[i][:, None], skew(np.eye(3)[i])]])
                for i in range(3))


def _quest_terms(B):
    """S, Z, sigma (seed 002 eq. 2.4), S², kappa = tr adj S and Delta = det S: what QUEST's characteristic
    polynomial and closed form are made of."""
    S, Z, sigma = _szs(B)
    S2 = S @ S
    kappa = 0.5 * (np.trace(S, axis1=-2, axis2=-1) ** 2 - np.trace(S2, axis1=-2, axis2=-1))
    return S, Z, sigma, S2, kappa, np.linalg.det(S)


def _quest_quaternion(terms, lam):
    """Shuster's optimal quaternion for ``lam`` (QUEST eq. 66-69), ours (scalar first, unnormalised)."""
    S, Z, sigma, S2, kappa, delta = terms
    alpha = lam * lam - sigma * sigma + kappa
    beta = lam - sigma
    gamma = (lam + sigma) * alpha - delta
    X = (alpha[..., None] * Z + beta[..., None] * np.einsum("...ij,...j->...i", S, Z)
         + np.einsum("...ij,...j->...i", S2, Z))
    return np.concatenate([gamma[..., None], X], axis=-1)


def quest(b, r, w=None, *, near_angle_deg: float = NEAR_ANGLE_DEG, max_iter: int = 60) -> Estimate:
    """Shuster's QUEST: the largest eigenvalue of ``K`` by Newton-Raphson on its characteristic polynomial
    from ``sum w``, then the quaternion in closed form. Near a rotation of 180° the closed form vanishes;
    Shuster & Oh's sequential rotations are used: the problem is also solved with the reference frame turned
    180° about x, y and z (the eigenvalue is the same), and each problem keeps the best-conditioned of the four.
    """
    b, r, w, scale = _observations(b, r, w)
    B = attitude_profile(b, r, w)
    terms = _quest_terms(B)
    S, Z, sigma, S2, kappa, delta = terms
    a = sigma * sigma - kappa
    bb = sigma * sigma + np.einsum("...i,...i->...", Z, Z)
    c = delta + np.einsum("...i,...ij,...j->...", Z, S, Z)
    d = np.einsum("...i,...ij,...j->...", Z, S2, Z)
    k0 = a * bb + c * sigma - d
    ab = a + bb
    lam = np.sum(w, axis=-1)
    for _ in range(max_iter):  # the characteristic equation, Newton from sum w (QUEST eq. 70-71)
        l2 = lam * lam
        step = ((l2 - ab) * l2 - c * lam + k0) / ((4 * l2 - 2 * ab) * lam - c)
        lam = lam - step
        if np.all(np.abs(step) <= 4e-16 * np.abs(lam)):
            break
    # the second eigenvalue: the largest root of the deflated cubic p(x) / (x - lam), Newton from lam
    c2, c1, c0 = lam, lam * lam - ab, lam * (lam * lam - ab) - c
    lam2 = lam.copy()
    for _ in range(max_iter):
        x2 = lam2 * lam2
        step = (x2 * lam2 + c2 * x2 + c1 * lam2 + c0) / (3 * x2 + 2 * c2 * lam2 + c1)
        lam2 = lam2 - step
        if np.all(np.abs(step) <= 4e-16 * np.abs(lam)):
            break
    # [X, gamma] is the scalar column of adj(lam I - K) = p'(lam) q q^T: its length is |p'(lam) q4|, the same
    # p'(lam) in every turned frame. Where |q4| < 0.4 (within 133° of a half turn), keep the longest of the four
    # frames: |q4'| >= 1/2 in one of them.
    q = _quest_quaternion(terms, lam)
    size = np.sum(q * q, axis=-1)
    slope = (4 * lam * lam - 2 * ab) * lam - c  # p'(lam)
    turn_at = np.nonzero((size < (0.4 * slope) ** 2).ravel())[0]
    if turn_at.size:
        shape = q.shape
        q, size = q.reshape(-1, 4), size.ravel()
        Bs, ls = B.reshape(-1, 3, 3)[turn_at], lam.ravel()[turn_at]
        qs, ss = q[turn_at], size[turn_at]
        for turn, unturn in zip(_TURNS, _UNTURN):
            qt = _quest_quaternion(_quest_terms(Bs * turn), ls)
            st = np.sum(qt * qt, axis=-1)
            better = st > ss
            qs = np.where(better[:, None], qt @ unturn.T, qs)
            ss = np.where(better, st, ss)
        q[turn_at] = qs
        q = q.reshape(shape)
    return _finish("quest", _refined(B, q, lam), b, r, w, scale, lam, lam2, near_angle_deg)


#: The shift of QUEST's inverse-iteration step above its eigenvalue, relative: the step shrinks the error of
#: the closed form by this over the eigenvalue gap (relative), 1e-12 / 3e-4 for directions 1° apart.
_SHIFT = 1e-12


def _refined(B, q, lam):
    """One step of inverse iteration on Davenport's ``K`` from QUEST's quaternion ``q``: the closed form
    loses digits as the eigenvalue gap closes (8e-9 rad with directions 1-2° apart); the step restores the
    q-method's accuracy (1e-11 rad there). ``K - mu I`` with ``mu`` just above the largest eigenvalue is
    negative definite, never singular."""
    K = davenport_k(B)
    mu = lam * (1 + _SHIFT) + np.finfo(float).tiny
    v = np.concatenate([q[..., 1:], q[..., :1]], axis=-1)  # scalar last, as K
    v = v / np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    x = np.linalg.solve(K - mu[..., None, None] * np.eye(4), v[..., None])[..., 0]
    return np.concatenate([x[..., 3:], x[..., :3]], axis=-1)


def svd_method(b, r, w=None, *, near_angle_deg: float = NEAR_ANGLE_DEG) -> Estimate:
    """Markley's SVD method: ``B = U diag(s) V^T``, ``A = U diag(1, 1, det U det V) V^T``; the eigenvalues of
    ``K`` follow from ``s`` (``lam = s1 + s2 + d s3``, the next ``s1 - s2 - d s3``)."""
    b, r, w, scale = _observations(b, r, w)
    U, s, Vt = np.linalg.svd(attitude_profile(b, r, w))
    d = np.linalg.det(U) * np.linalg.det(Vt)
    A = U @ (np.concatenate([np.ones(d.shape + (2,)), d[..., None]], axis=-1)[..., :, None] * Vt)
    q = dcm_to_quat(np.swapaxes(A, -1, -2))
    return _finish("svd", q, b, r, w, scale, s[..., 0] + s[..., 1] + d * s[..., 2],
                   s[..., 0] - s[..., 1] - d * s[..., 2], near_angle_deg)


def _triad_stacked(b, r, w=None, **kw) -> Estimate:
    """TRIAD on the first two observations of ``(..., N, 3)`` stacks, the first as its better sensor."""
    b, r = _array(b, "b"), _array(r, "r")
    if b.ndim < 2 or b.shape != r.shape or b.shape[-2] < 2:
        _vectors(b, r)  # its refusal
    w = None if w is None else np.asarray(w, dtype=float)[..., :2]
    return triad(b[..., 0, :], b[..., 1, :], r[..., 0, :], r[..., 1, :], w=w, **kw)


#: name -> solver of the stacked problem ``(b, r, w)``.
METHODS = {"triad": _triad_stacked, "q-method": q_method, "quest": quest, "svd": svd_method}


def determine(method: str, b, r, w=None, **kw) -> Estimate:
    """``METHODS[method](b, r, w)``, the method named."""
    if method not in METHODS:
        raise DeterminationError(f"method: unknown {method!r}; expected one of {', '.join(METHODS)}")
    return METHODS[method](b, r, w, **kw)
