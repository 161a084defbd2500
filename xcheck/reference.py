"""The truth every trajectory is measured against.

* :func:`exact_torque_free` — the exact torque-free motion of any rigid body: the closed form
  ``R(t) = exp(t [h]x / I_t) R0 exp(-t lambda [a]x)`` for axisymmetric and spherical bodies, Jacobi elliptic
  functions for asymmetric ones with the rotation about the fixed angular momentum by Gauss-Legendre quadrature.
* :func:`lagrange_top` — the exact motion of a heavy symmetric top (Lagrange's case): the nutation through a Jacobi
  elliptic function, precession and spin by Gauss-Legendre quadrature; :func:`exact_reference` picks the closed form
  a body and its torque have.
* :func:`dop853` — scipy's DOP853 at rtol 1e-13, atol 1e-15 (torqued cases).
* the thesis's own "fine" reference (a method at dt = 1e-4 s, seed 004 §3.3) is a scenario option, run by the
  study (:mod:`xcheck.study`) through the same runners as every method.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy.special import ellipk

from . import rotations as rot
from .elliptic import complete_k, elliptic_argument, legendre_pi
from .body import principal_axes, validate_inertia
from .trajectory import check_initial_state, continuous_quaternions

__all__ = ["exact_torque_free", "exact_reference", "exact_kind", "exact_why_not", "exact_gyrostat", "gyrostat_why_not", "lagrange_top", "lagrange_why_not", "dop853", "dop853_solution", "rigid_body_rhs", "EQUAL_MOMENTS_RTOL",
           "ReferenceFailure", "solve_bounded", "own_period"]

#: Principal moments closer than this (relative to the largest) are equal (axisymmetry): the round-off of the
#: principal moments of a turned tensor. Any larger difference is the body's own and the elliptic solution takes
#: it (exact as the moments close up: m -> 0). (1e-12 here once made a body of moments 1e-12 apart turning at
#: 100 rad/s axisymmetric, 1e-9 rad off after 10 s.)
EQUAL_MOMENTS_RTOL = 4 * np.finfo(float).eps
#: A top's or a gyrostat's inertia is symmetric about its axis (Lagrange's top, the axisymmetric gyrostat) when it
#: departs from the symmetric tensor by at most this, relative to its norm (else no closed form: DOP853).
SYMMETRY_RTOL = 1e-14
#: Quadrature panels span at most this much of the elliptic argument tau (10 Gauss-Legendre nodes each).
_PANEL_TAU = 0.25
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(10)
#: At most this many quadrature panels in one evaluation (memory: ~10 floats a node, 10 nodes a panel).
_MAX_PANELS = 2_000_000


class ReferenceFailure(RuntimeError):
    """A reference (or scipy solver run) that cannot be computed within its budget; the message says why
    and what to change."""


def _inputs(inertia, q0, omega0, t):
    I = validate_inertia(inertia)
    q0, omega0 = check_initial_state(q0, omega0)
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or not np.all(np.isfinite(t)):
        raise ValueError("t: expected a 1-D array of finite times [s]")
    return I, q0, omega0, t


def exact_torque_free(inertia, q0, omega0, t):
    """Exact torque-free attitude and body rate at times ``t``.

    Parameters
    ----------
    inertia : array_like (3,) or (3, 3)
        Principal moments or tensor in body components [kg m^2] (a full tensor is rotated to principal axes).
    q0 : (4,) initial attitude [w, x, y, z], body -> world.
    omega0 : (3,) initial body rate [rad/s].
    t : (n,) times [s].

    Returns
    -------
    q : ndarray (n, 4), sign-continuous; omega : ndarray (n, 3)
    """
    I, q0, omega0, t = _inputs(inertia, q0, omega0, t)
    moments, V = principal_axes(I)
    qV = rot.dcm_to_quat(V)  # principal -> body
    qp, wp = _principal(moments, rot.quat_mul(q0, qV), V.T @ omega0, t)
    q = rot.quat_mul(qp, rot.quat_conj(qV))
    return continuous_quaternions(q), wp @ V.T


def _principal(J, q0, w0, t):
    """Exact motion in the principal frame, moments ``J`` ascending."""
    Jw = J * w0
    scale = J[2]
    if np.linalg.norm(np.cross(w0, Jw)) <= 1e-15 * np.linalg.norm(w0) * np.linalg.norm(Jw) or not np.any(w0):
        # steady rotation about a principal axis (or a spherical body): R(t) = R0 exp(t [w0 x])
        return rot.quat_mul(q0, rot.rotvec_to_quat(t[:, None] * w0)), np.tile(w0, (len(t), 1))
    if J[1] - J[0] <= EQUAL_MOMENTS_RTOL * scale:
        return _axisymmetric(J, 2, q0, w0, t)
    if J[2] - J[1] <= EQUAL_MOMENTS_RTOL * scale:
        return _axisymmetric(J, 0, q0, w0, t)
    return _asymmetric(J, q0, w0, t)


def _axisymmetric(J, axis, q0, w0, t):
    """Closed form: ``R(t) = exp(t [h]x / I_t) R0 exp(-t lam [a]x)``, ``lam = (I_a - I_t)(a.w0)/I_t``;
    body rate ``w(t) = exp(t lam [a]x) (I w0 / I_t) - lam a``."""
    a = np.zeros(3)
    a[axis] = 1.0
    I_a = J[axis]
    I_t = np.mean(np.delete(J, axis))
    h_body = J * w0
    h_world = rot.quat_rotate(q0, h_body)
    lam = (I_a - I_t) * w0[axis] / I_t
    world_turn = rot.rotvec_to_quat(t[:, None] * (h_world / I_t))
    body_turn = rot.rotvec_to_quat(-t[:, None] * lam * a)
    q = rot.quat_mul(rot.quat_mul(world_turn, q0), body_turn)
    omega = rot.quat_rotate(rot.quat_conj(body_turn), np.broadcast_to(h_body / I_t, (len(t), 3))) - lam * a
    return q, omega


def _asymmetric(J, q0, w0, t):
    """Jacobi elliptic functions for the body rate; a 3-1-3 chart on a world frame whose z is the fixed
    angular momentum for the attitude, its precession angle in closed form (Legendre's third integral,
    :func:`~xcheck.elliptic.legendre_pi`): exact at every time on its own, whatever the grid."""
    # The parameters come from the moments' differences and the rates in exact rational arithmetic, rounded once:
    # h^2 - 2 E J2, which decides the motion near the intermediate axis's separatrix, is a difference of two
    # nearly equal terms there (in floating point it kept 1e-6 of its value at 1e-10 from the separatrix), and
    # E2 J3 - h^2 loses the digits of a near-isotropic body's differences. So m and 1 - m are each correct to
    # the last bit, and every parameter belongs to the one body (J, w0).
    Jq, wq = [Fraction(float(v)) for v in J], [Fraction(float(v)) for v in w0]
    Z = Jq[2] * wq[2] ** 2 * (Jq[2] - Jq[1]) - Jq[0] * wq[0] ** 2 * (Jq[1] - Jq[0])  # h^2 - 2 E J2
    # the axis the body rate circulates about: the largest moment if h^2 >= 2 E J2, else the smallest;
    # relabel it axis 3 with a proper rotation P (body comps = P @ relabelled comps)
    if Z >= 0:
        P, order, signs = np.eye(3), (0, 1, 2), (1, 1, 1)
    else:
        P = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])  # columns e3, -e2, e1; det +1
        order, signs, Z = (2, 1, 0), (1, -1, 1), -Z
    qP = rot.dcm_to_quat(P)
    J = np.abs(P.T @ J)  # moments relabelled (P is a signed permutation): ascending, or descending
    w = P.T @ w0
    J1q, J2q, J3q = (Jq[i] for i in order)
    w1q, w2q, w3q = (s * wq[i] for s, i in zip(signs, order))
    q_start = rot.quat_mul(q0, qP)
    J1, J2, J3 = J
    D31, D32, D21 = J3q - J1q, J3q - J2q, J2q - J1q  # signed: all negative when descending
    X = J1q * w1q ** 2 * D31 + J2q * w2q ** 2 * D32  # 2 E J3 - h^2
    Y = J2q * w2q ** 2 * D21 + J3q * w3q ** 2 * D31  # h^2 - 2 E J1
    A1 = np.sqrt(float(X / (J1q * D31)))
    A2 = np.sqrt(float(X / (J2q * D32)))
    A3 = np.sqrt(float(Y / (J3q * D31)))
    lam = np.sqrt(float(D32 * Y / (J1q * J2q * J3q)))
    m, m1 = float(D21 * X / (D32 * Y)), float(D31 * (Z if D31 > 0 else -Z) / (D32 * Y))  # m + m1 = 1
    n = float(-J3q * D21 / (J1q * D32))
    s3 = 1.0 if w[2] >= 0 else -1.0
    s2 = s3 * np.sign(float(D32))  # from Euler's equations: w2 = s2 A2 sn keeps I2 w2' = (I3 - I1) w3 w1
    sn0, cn0 = w[1] / (s2 * A2), w[0] / A1
    r = np.hypot(sn0, cn0)
    tau0 = elliptic_argument(sn0 / r, cn0 / r, m1)
    h = float(np.linalg.norm(J * w))
    # psi' = h (J1 w1^2 + J2 w2^2) / ((J1 w1)^2 + (J2 w2)^2) = h/J3 + h (J3 - J1) / (J1 J3 (1 - n sn^2)) with
    # n = J3 (J1 - J2) / (J1 (J3 - J2)) <= 0 (energy and momentum eliminate w1, w2; the same in either labelling):
    # psi = h t / J3 + h (J3 - J1) / (J1 J3 lam) [Pi(n; am tau) - Pi(n; am tau0)], tau = lam t + tau0
    (sn, cn, dn), pi_t = legendre_pi(n, m, m1, lam * t + tau0)
    _, pi_0 = legendre_pi(n, m, m1, np.array([tau0]))
    psi = h * t / J3 + h * float(D31) / (J1 * J3 * lam) * (pi_t - pi_0[0])
    omega = np.stack([A1 * cn, s2 * A2 * sn, s3 * A3 * dn], axis=-1)
    Jw = omega * J
    theta = np.arctan2(np.hypot(Jw[:, 0], Jw[:, 1]), Jw[:, 2])
    phi = np.arctan2(Jw[:, 0], Jw[:, 1])
    Jw0 = w * J
    theta0 = np.arctan2(np.hypot(Jw0[0], Jw0[1]), Jw0[2])
    phi0 = np.arctan2(Jw0[0], Jw0[1])
    # world frame H with z along h: R_WH = R0 (Rx(theta0) Rz(phi0))^T, so that psi(0) = 0
    q_WH = rot.quat_mul(q_start, rot.quat_conj(rot.euler_to_quat([0.0, theta0, phi0], "313")))
    q = rot.quat_mul(q_WH, rot.euler_to_quat(np.stack([psi, theta, phi], axis=-1), "313"))
    return rot.quat_mul(q, rot.quat_conj(qP)), omega @ P.T


# ------------------------------------------------------------------------------------------------
# the heavy symmetric top (Lagrange's case)
# ------------------------------------------------------------------------------------------------
#: The top's axis must stay this far from the vertical (1 - cos theta, both turning points) for the closed form:
#: its precession rate (a - b u)/(1 - u^2) loses digits as 1 - u^2 does.
LAGRANGE_MIN_SIN2 = 1e-4


def lagrange_why_not(inertia, centre, force) -> str | None:
    """Why the motion of a body under the torque ``c x (R^T F)`` (a top: ``c`` its centre of mass from the pivot,
    body frame; ``F = m g``, world frame) has no closed form here, or None when it does: Lagrange's top, the inertia
    about the pivot symmetric about the axis through ``c``."""
    I = validate_inertia(inertia)
    c, F = np.asarray(centre, dtype=float), np.asarray(force, dtype=float)
    if not np.any(c) or not np.any(F):
        return "no torque: the torque-free solution applies"
    if symmetric_moments(I, c) is None:
        return ("the inertia about the pivot is not symmetric about the axis through the centre of mass (Lagrange's "
                "top): no closed form; use 'dop853'")
    return None


def symmetric_moments(inertia, axis) -> tuple[float, float] | None:
    """``(A, C)`` when the inertia tensor is ``A (E - e e^T) + C e e^T`` about the direction ``e`` of ``axis`` (an
    axisymmetric body, to :data:`SYMMETRY_RTOL` of its norm): the transverse and the axial moment."""
    I = np.asarray(inertia, dtype=float)
    e = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    C = e @ I @ e
    A = 0.5 * (np.trace(I) - C)
    if np.linalg.norm(I - A * np.eye(3) - (C - A) * np.outer(e, e)) > SYMMETRY_RTOL * np.linalg.norm(I):
        return None
    return float(A), float(C)


def gyrostat_why_not(inertia, h) -> str | None:
    """Why a gyrostat with the constant internal momentum ``h`` (body components) has no closed form here, or None
    when it has one (:func:`exact_gyrostat`): the inertia symmetric about ``h``'s direction."""
    I = validate_inertia(inertia)
    h = np.asarray(h, dtype=float)
    if np.any(h) and symmetric_moments(I, h) is None:
        return ("the inertia (less the wheels' axial moments) is not symmetric about the wheels' momentum: the "
                "gyrostat's motion is elliptic (Volterra), not in closed form here; use 'dop853'")
    return None


def exact_gyrostat(inertia, q0, omega0, t, h):
    """Exact motion of an axisymmetric gyrostat (issue 28): ``I w' + w x (I w + h) = 0`` with ``h`` constant along
    the symmetry axis ``e`` of ``I`` (a free wheel on it, or one turning at a constant speed). Like the
    torque-free axisymmetric body (:func:`_axisymmetric`) with the body-cone rate shifted: the momentum ``H = I w + h``
    is fixed in the world, ``w = H / A + (w_e - H_e / A) e``, so ``R(t) = exp(t [H_world]x / A) R0 exp(-t lam [e]x)``
    with ``lam = ((C - A) w_e + |h|) / A`` (``A`` the transverse moment, ``C`` the axial one)."""
    I, q0, omega0, t = _inputs(inertia, q0, omega0, t)
    why = gyrostat_why_not(I, h)
    if why is not None:
        raise ReferenceFailure(f"the exact reference: {why}")
    h = np.asarray(h, dtype=float)
    if not np.any(h):
        return exact_torque_free(I, q0, omega0, t)
    e = h / np.linalg.norm(h)
    F = rot.frame_with_z(e)  # a frame of the body whose z is e: principal, as I is symmetric about e
    qF = rot.dcm_to_quat(F)
    A, C = symmetric_moments(I, e)
    w = F.T @ omega0
    H = np.array([A * w[0], A * w[1], C * w[2] + np.linalg.norm(h)])  # in the frame F
    qf0 = rot.quat_mul(q0, qF)
    lam = ((C - A) * w[2] + np.linalg.norm(h)) / A
    z = np.array([0.0, 0.0, 1.0])
    world_turn = rot.rotvec_to_quat(t[:, None] * (rot.quat_rotate(qf0, H) / A))
    body_turn = rot.rotvec_to_quat(-t[:, None] * lam * z)
    q = rot.quat_mul(rot.quat_mul(world_turn, qf0), body_turn)
    omega = rot.quat_rotate(rot.quat_conj(body_turn), np.broadcast_to(H / A, (len(t), 3))) - lam * z
    return continuous_quaternions(rot.quat_mul(q, rot.quat_conj(qF))), omega @ F.T


def exact_why_not(inertia, torque) -> str | None:
    """Why a body under ``torque`` (None: torque free) has no exact reference here, or None when it has one: torque
    free (:func:`exact_torque_free`), Lagrange's top (:func:`lagrange_top`: a torque ``c x (R^T F)`` with ``c``
    and ``F`` fixed, the inertia symmetric about ``c``), or an axisymmetric gyrostat whose wheels' momentum is
    constant, along the axis (:func:`exact_gyrostat`)."""
    if torque is None:
        return None
    if getattr(torque, "conserves_momentum", False) and not getattr(torque, "terms", None):  # wheels alone
        if len(torque.commands):
            return "a motor changes the wheels' momentum: no closed form; use 'dop853'"
        return gyrostat_why_not(inertia, torque.h0)
    form = torque.fixed_form() if hasattr(torque, "fixed_form") else None
    if form is None:
        return f"'exact' is the torque-free solution or Lagrange's top, and the torque is {torque.describe()}"
    return lagrange_why_not(inertia, *form)


def exact_reference(inertia, q0, omega0, t, torque=None):
    """The exact motion under ``torque`` (see :func:`exact_why_not`): ``q`` (n, 4), ``omega`` (n, 3)."""
    if torque is None:
        return exact_torque_free(inertia, q0, omega0, t)
    why = exact_why_not(inertia, torque)
    if why is not None:
        raise ReferenceFailure(f"the exact reference: {why}")
    if getattr(torque, "conserves_momentum", False):
        return exact_gyrostat(inertia, q0, omega0, t, torque.h0)
    centre, force = torque.fixed_form()
    return lagrange_top(inertia, q0, omega0, t, centre=centre, force=force)


def lagrange_top(inertia, q0, omega0, t, *, centre, force):
    """Exact motion of a heavy symmetric top (Lagrange's case) at times ``t``: the body turns about a fixed point
    under the torque ``c x (R^T F)`` (``c`` the centre of mass from the pivot, body frame; ``F = m g``, world
    frame), its inertia about the pivot ``diag(A, A, C)`` about the axis through ``c`` (:func:`lagrange_why_not`).

    In 3-1-3 Euler angles of the top's axis about the upward vertical (precession psi, nutation theta, spin phi),
    ``u = cos theta`` obeys ``u'^2 = (alpha - beta u)(1 - u^2) - (a - b u)^2`` (alpha = 2 E'/A with E' the energy
    less the spin's, beta = 2 m g l / A, a = L_z / A, b = L_3 / A, both momenta conserved), a cubic with roots
    u1 <= u <= u2 <= 1 <= u3 (:func:`_top_roots`: found about ``u0``, where they are well conditioned, a double
    root at steady precession included), so ``u = u1 + (u2 - u1) sn^2(lam t + tau0, k)`` with
    ``lam = sqrt(beta (u3 - u1)) / 2`` and ``k^2 = (u2 - u1)/(u3 - u1)``. The precession ``psi' = (a - b u)/(1 - u^2)``
    and the spin ``phi' = L_3/C - u psi'`` are, by partial fractions, ``psi' = (a - b)/(2 (1 - u)) + (a + b)/(2 (1 + u))``
    and ``phi' = L_3/C - b - (a - b)/(2 (1 - u)) + (a + b)/(2 (1 + u))``, whose integrals are Legendre's third
    integrals (:func:`~xcheck.elliptic.legendre_pi`): closed forms at every time, no quadrature. Returns ``q``
    (n, 4), sign-continuous, and ``omega`` (n, 3), body frame. :class:`ReferenceFailure` when the axis comes within
    :data:`LAGRANGE_MIN_SIN2` of the vertical."""
    I, q0, omega0, t = _inputs(inertia, q0, omega0, t)
    top = _top_state(I, q0, omega0, centre, force)
    roots, b, wT, theta_dot0 = _top_cubic(top), top.b, top.wT, top.theta_dot0
    x1, x2, x3 = roots.x1, roots.x2, roots.x3
    one_minus_u0, one_plus_u0, psi0, phi0, beta = top.one_minus_u0, top.one_plus_u0, top.psi0, top.phi0, top.beta
    a_minus_b, a_plus_b = top.P - b * one_minus_u0, top.P + b * one_plus_u0
    span = x2 - x1
    lam = 0.5 * np.sqrt(beta * (x3 - x1))
    m, m1 = span / (x3 - x1), (x3 - x2) / (x3 - x1)
    if span > 0:  # sn^2(tau0) = (u0 - u1) / (u2 - u1), cn^2(tau0) = (u2 - u0) / (u2 - u1)
        tau0 = elliptic_argument(np.sqrt(-x1 / span), np.sqrt(x2 / span), m1)
        if theta_dot0 > 0:  # u = cos theta falling: the elliptic argument runs the other way from u0
            tau0 = -tau0
    else:  # steady precession: no nutation
        tau0 = 0.0
    # 1 - u = (1 - u1)(1 - n_minus sn^2) = (1 - u2) + span cn^2 and 1 + u = (1 + u1)(1 - n_plus sn^2), each side a sum
    # of terms >= 0: accurate however close the axis comes to either vertical
    one_minus_u1, one_plus_u1 = one_minus_u0 - x1, roots.y1
    n_minus, n_plus = span / one_minus_u1, -span / one_plus_u1

    def integrals(tt):
        """sn, cn, dn at ``tt`` and the integrals from 0 of 1/(1 - u) and 1/(1 + u)."""
        tau = lam * tt + tau0
        (sn, cn, dn), pm = legendre_pi(n_minus, m, m1, tau, one_minus_n=roots.z2 / one_minus_u1)
        _, pp = legendre_pi(n_plus, m, m1, tau)
        _, pm0 = legendre_pi(n_minus, m, m1, np.array([tau0]), one_minus_n=roots.z2 / one_minus_u1)
        _, pp0 = legendre_pi(n_plus, m, m1, np.array([tau0]))
        return sn, cn, dn, (pm - pm0[0]) / (one_minus_u1 * lam), (pp - pp0[0]) / (one_plus_u1 * lam)

    sn, cn, dn, i_minus, i_plus = integrals(t)
    psi = psi0 + 0.5 * a_minus_b * i_minus + 0.5 * a_plus_b * i_plus
    phi = phi0 + (wT[2] - b) * t - 0.5 * a_minus_b * i_minus + 0.5 * a_plus_b * i_plus
    u_dot = 2 * span * lam * sn * cn * dn
    one_minus_u, one_plus_u = roots.z2 + span * cn * cn, roots.y1 + span * sn * sn
    u = 0.5 * (one_plus_u - one_minus_u)
    sin_theta = np.sqrt(one_minus_u * one_plus_u)
    theta = np.arctan2(sin_theta, u)
    psi_dot = 0.5 * a_minus_b / one_minus_u + 0.5 * a_plus_b / one_plus_u
    rates = np.stack([psi_dot, -u_dot / sin_theta, wT[2] - u * psi_dot], axis=-1)
    angles = np.stack([psi, theta, phi], axis=-1)
    q = rot.quat_mul(rot.quat_mul(top.qG, rot.euler_to_quat(angles, "313")), rot.quat_conj(top.qB))
    omega = rot.euler_rates_to_omega(angles, rates, "313") @ top.B.T
    return continuous_quaternions(q), omega


@dataclass(frozen=True)
class _TopState:
    """A heavy symmetric top's start in its own frames (:func:`lagrange_top`): the body's top frame ``B`` (columns,
    the third along the centre of mass) and the world's vertical frame ``G`` (its z upward), ``qT`` the top frame ->
    vertical frame, ``wT`` the body rate in the top frame, the 3-1-3 angles ``psi0``, ``phi0``, ``1 -+ u0`` (u0 =
    cos theta0), ``beta = 2 m g l / A``, ``b = L_3 / A``, ``P = a - b u0 = psi0' sin^2 theta0`` and ``theta_dot0``."""

    A: float
    C: float
    B: np.ndarray
    qB: np.ndarray
    qG: np.ndarray
    wT: np.ndarray
    psi0: float
    phi0: float
    one_minus_u0: float
    one_plus_u0: float
    beta: float
    b: float
    P: float
    theta_dot0: float


def _top_state(I, q0, omega0, centre, force) -> _TopState:
    why = lagrange_why_not(I, centre, force)
    if why is not None:
        raise ReferenceFailure(f"the exact heavy-top reference: {why}")
    c, F = np.asarray(centre, dtype=float), np.asarray(force, dtype=float)
    e3 = c / np.linalg.norm(c)
    C = e3 @ I @ e3
    A = 0.5 * (np.trace(I) - C)
    B = rot.frame_with_z(e3)  # body components of the top's axes (columns), the third along c
    G = rot.frame_with_z(-F / np.linalg.norm(F))  # world components of the vertical frame, its z upward
    qB, qG = rot.dcm_to_quat(B), rot.dcm_to_quat(G)
    qT = rot.quat_mul(rot.quat_mul(rot.quat_conj(qG), q0), qB)  # top frame -> vertical frame
    wT = B.T @ omega0
    psi0, _, phi0 = rot.quat_to_euler(qT, "313", warn=False)
    R = rot.quat_to_dcm(qT)
    Mgl = float(np.linalg.norm(F) * np.linalg.norm(c))
    return _TopState(A=float(A), C=float(C), B=B, qB=qB, qG=qG, wT=wT, psi0=float(psi0), phi0=float(phi0),
                     one_minus_u0=2.0 * (qT[1] ** 2 + qT[2] ** 2),  # 1 - cos theta0 = 2 sin^2(theta0/2), no cancellation
                     one_plus_u0=2.0 * (qT[0] ** 2 + qT[3] ** 2), beta=2 * Mgl / A, b=C * wT[2] / A,
                     # a - b u0 = psi0' sin^2 theta0 (L_z - L_3 u0 over A: the spin's part cancelled)
                     P=R[2, 0] * wT[0] + R[2, 1] * wT[1],
                     theta_dot0=wT[0] * np.cos(phi0) - wT[1] * np.sin(phi0))  # from the 3-1-3 rates


def _top_cubic(top: _TopState) -> "_TopRoots":
    """The cubic's roots of a top (:func:`_top_roots`), or :class:`ReferenceFailure` where its axis comes within
    :data:`LAGRANGE_MIN_SIN2` of the vertical."""
    near = min(top.one_minus_u0, top.one_plus_u0)  # the start's distance from the nearer vertical, 1 -+ cos theta0
    roots = None
    if near * (2 - near) >= LAGRANGE_MIN_SIN2:
        roots = _top_roots(top.beta, top.theta_dot0, top.P, top.b, top.one_minus_u0, top.one_plus_u0)
        near = min(roots.y1, roots.z2)
    if near * (2 - near) < LAGRANGE_MIN_SIN2:
        raise ReferenceFailure(f"the exact heavy-top reference: the axis comes within "
                               f"{np.degrees(2 * np.arcsin(np.sqrt(near / 2))):.3g} deg of the vertical, where "
                               "its precession rate loses digits; use 'dop853'")
    return roots


@dataclass(frozen=True)
class _TopRoots:
    """The cubic's roots about the top's start ``u0``: ``x1 = u1 - u0 <= 0 <= x2 = u2 - u0`` (the turning points of
    ``u = cos theta``), ``x3 = u3 - u0 >= 1 - u0``, and the turning points' distances from the verticals, ``y1 = 1 + u1``
    and ``z2 = 1 - u2``, each found as a root of its own (``1 + u0 + x1`` would lose the digits of a top hanging
    nearly straight down, ``1 - u0 - x2`` those of one nearly asleep)."""

    x1: float
    x2: float
    x3: float
    y1: float
    z2: float


def _top_roots(beta, theta_dot0, P, b, one_minus_u0, one_plus_u0) -> _TopRoots:
    """The roots of ``f(u) = (alpha - beta u)(1 - u^2) - (a - b u)^2`` (:func:`lagrange_top`) from the top's state:
    ``theta_dot0``, ``P = a - b u0 = psi0' sin^2 theta0``, ``b = L_3 / A`` and ``1 -+ u0``. Its coefficients are
    formed in exact rational arithmetic from these (the transverse rate squared ``alpha - beta u0`` is
    ``theta0'^2 + P^2 / sin^2 theta0``, so ``f(u0) = (sin theta0 theta0')^2 >= 0`` exactly) and written about ``u0``,
    ``-1`` and ``+1`` (Taylor shifts, exact too): each root is then bracketed where its polynomial is accurate, by
    Brent's method, to the last bits of its own size, a near-double root (near steady precession: ``x1`` and ``x2``
    both close to 0) included, since ``f``'s error about ``u0`` is proportional to ``x``. Started at a turning point
    (``theta0' = 0``), 0 is a root and the other comes from the quadratic left once it is divided out; ``x3`` from the
    roots' sum."""
    from scipy.optimize import brentq

    Fr = Fraction
    sm, sp = Fr(float(one_minus_u0)), Fr(float(one_plus_u0))
    sm, sp = 2 * sm / (sm + sp), 2 * sp / (sm + sp)  # 1 - u0 and 1 + u0 of one u0: (1 - u0)(1 + u0) = sin^2 theta0
    u0 = (sp - sm) / 2
    beta_, P_, b_, td = Fr(float(beta)), Fr(float(P)), Fr(float(b)), Fr(float(theta_dot0))
    s0 = sm * sp  # sin^2 theta0
    W = td * td + P_ * P_ / s0
    alpha, a = W + beta_ * u0, P_ + b_ * u0
    # f(u) = (alpha - beta u)(1 - u^2) - (a - b u)^2, ascending coefficients
    poly = [alpha - a * a, -beta_ + 2 * a * b_, -alpha - b_ * b_, beta_]

    def about(c):  # the coefficients of f(c + x), as floats
        p0 = ((poly[3] * c + poly[2]) * c + poly[1]) * c + poly[0]
        p1 = (3 * poly[3] * c + 2 * poly[2]) * c + poly[1]
        p2 = 3 * poly[3] * c + poly[2]
        return [float(p0), float(p1), float(p2), float(poly[3])]

    def root(coef, lo, hi):
        def f(x):
            return coef[0] + x * (coef[1] + x * (coef[2] + coef[3] * x))
        flo, fhi = f(lo), f(hi)
        if flo == 0 or fhi == 0 or (flo > 0) == (fhi > 0):
            return lo if abs(flo) <= abs(fhi) else hi
        return brentq(f, lo, hi, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=2000)

    c = about(u0)  # c[0] = (sin theta0 theta0')^2 >= 0
    lo, hi = -float(sp), float(sm)
    if c[0] == 0.0:  # at a turning point: x = 0 is a root, the others those of beta x^2 + c2 x + c1 (their product c1 /
        # beta): both > 0 when c1 > 0 (u0 is u1: x2 and x3), of either sign when c1 < 0 (u0 is u2: x1 and x3)
        disc = np.sqrt(max(c[2] * c[2] - 4 * c[3] * c[1], 0.0))
        qq = -0.5 * (c[2] + np.copysign(disc, c[2]))
        r = sorted((qq / c[3], c[1] / qq)) if qq != 0 else [0.0, 0.0]
        if c[1] > 0:
            x1, x2 = 0.0, float(np.clip(r[0], 0.0, hi))
        elif c[1] < 0:
            x1, x2 = float(np.clip(r[0], lo, 0.0)), 0.0
        else:  # steady precession: a double root
            x1 = x2 = 0.0
    else:
        x1, x2 = root(c, lo, 0.0), root(c, 0.0, hi)
    x3 = max(-c[2] / c[3] - x1 - x2, hi)
    # 1 + u1 = (1 + u0) + x1 loses digits only where u1 is nearer -1 than u0: there it is the root of f(-1 + y)
    # between 0 (f(-1) = -(a + b)^2 <= 0) and halfway from u1 to u0 (f > 0 there, between the turning points),
    # whose polynomial is accurate for small y; 1 - u2 likewise from +1
    y1, z2 = float(sp) + x1, float(sm) - x2
    if y1 < 0.5 * float(sp):
        y1 = root(about(Fr(-1)), 0.0, float(sp) + 0.5 * x1)
    if z2 < 0.5 * float(sm):
        top = about(Fr(1))
        z2 = root([top[0], -top[1], top[2], -top[3]], 0.0, float(sm) - 0.5 * x2)
    return _TopRoots(x1, x2, x3, y1, z2)


# ------------------------------------------------------------------------------------------------
# numerical references
# ------------------------------------------------------------------------------------------------
def rigid_body_rhs(inertia, torque=None):
    """``f(t, y)`` for ``y = [q (4), omega (3)]``: ``q' = 1/2 q ⊗ (0, w)``, ``w' = I^-1 (t - w x I w)``;
    the torque is evaluated with the normalised ``q``."""
    I = validate_inertia(inertia)
    Iinv = np.linalg.inv(I)

    def f(t, y):
        q, w = y[:4], y[4:]
        tau = 0.0 if torque is None else np.asarray(torque(t, q / np.sqrt(q @ q), w), dtype=float)
        qd = 0.5 * np.array([-q[1] * w[0] - q[2] * w[1] - q[3] * w[2],
                             q[0] * w[0] + q[2] * w[2] - q[3] * w[1],
                             q[0] * w[1] + q[3] * w[0] - q[1] * w[2],
                             q[0] * w[2] + q[1] * w[1] - q[2] * w[0]])
        h = I @ w
        wxh = np.array([w[1] * h[2] - w[2] * h[1], w[2] * h[0] - w[0] * h[2], w[0] * h[1] - w[1] * h[0]])
        if not np.all(np.isfinite(tau)):  # scipy's DOP853 would spin inside one step for ever
            raise ReferenceFailure(f"the torque is not finite at t = {t:.6g} s ({np.ravel(tau).tolist()} N m at omega = "
                                   f"{w.tolist()} rad/s): no solver can step through it")
        wd = Iinv @ (tau - wxh)  # (np.cross costs ten times more on 3-vectors)
        return np.concatenate([qd, wd])

    return f


#: The effort bound of a scipy solver run: at most this many steps, and this many seconds of wall time.
SOLVER_MAX_STEPS = 100_000
SOLVER_MAX_SECONDS = 60.0
#: DOP853 at rtol 1e-13 takes 3.6-5.8 steps per radian turned on the bundled scenarios: a run whose
#: ``|omega0| T`` predicts more steps than the budget is refused before it starts.
_DOP853_STEPS_PER_RAD = 3.0
#: Where ``|omega0|`` cannot see it (wheels' momentum, a torque that spins the body up), a solver's pace tells: from
#: this share of its step budget on, a run whose steps so far plus its recent pace (over its last fifth of steps) kept
#: to the end come to more than :data:`_PROJECTED_OVER` budgets gives up at once (a gyrostat's wheels once had DOP853
#: step 68 s before failing; a spin-up's pace grows, so it is caught later, never sooner than it should be).
_PROJECT_AFTER = 0.02
_PROJECTED_OVER = 1.5


def solve_bounded(method, fun, y0, duration: float, *, rtol: float, atol: float, what: str,
                  max_steps: int | None = None, max_seconds: float | None = None, breakpoints=()):
    """scipy's ``method`` (an ``OdeSolver`` class) from 0 to ``duration`` with a bounded effort; returns the
    dense :class:`scipy.integrate.OdeSolution`. :class:`ReferenceFailure` (naming ``what``) when the solver
    fails, the state becomes non-finite, or the run takes more than ``max_steps`` steps or ``max_seconds``
    (default :data:`SOLVER_MAX_STEPS`, :data:`SOLVER_MAX_SECONDS`). ``breakpoints``: times in (0, duration)
    where ``fun`` is not smooth (a table's rows): the solver restarts at each, so that no step straddles one
    (an error estimate across a kink is no estimate; DOP853 rejected step after step there). A run whose pace
    projects far past the budget (:data:`_PROJECTED_OVER` budgets, judged after :data:`_PROJECT_AFTER` of it) gives
    up then, saying how many steps it would need."""
    import time

    from scipy.integrate import OdeSolution

    max_steps = SOLVER_MAX_STEPS if max_steps is None else max_steps
    max_seconds = SOLVER_MAX_SECONDS if max_seconds is None else max_seconds
    ends = [float(b) for b in np.unique(breakpoints) if 0 < b < duration] + [float(duration)]
    ts, pieces = [0.0], []
    start = time.perf_counter()
    y, t0 = np.asarray(y0, dtype=float), 0.0
    for t1 in ends:
        solver = method(fun, t0, y, t1, rtol=rtol, atol=atol)
        while solver.status == "running":
            message = solver.step()
            if solver.status == "failed":
                raise ReferenceFailure(f"{what} failed at t = {solver.t:.6g} s: {message}")
            if not np.all(np.isfinite(solver.y)):
                raise ReferenceFailure(f"{what} became non-finite at t = {solver.t:.6g} s")
            ts.append(solver.t)
            pieces.append(solver.dense_output())
            elapsed = time.perf_counter() - start
            n = len(pieces)
            if n >= max(_PROJECT_AFTER * max_steps, 100) and solver.t < duration:
                k = n // 5
                need = n + k * (duration - solver.t) / max(solver.t - ts[-k - 1], 1e-300)
                if need > _PROJECTED_OVER * max_steps:
                    raise ReferenceFailure(
                        f"{what} would need about {need:.2g} steps at its pace so far ({n} steps to "
                        f"t = {solver.t:.6g} of {duration:g} s; its budget: {max_steps} steps): the motion is too "
                        f"fast to resolve at rtol {rtol:g} over this duration; shorten the duration or lower the rates")
            if solver.t < duration and (n >= max_steps or elapsed > max_seconds):
                raise ReferenceFailure(
                    f"{what} gave up at t = {solver.t:.6g} of {duration:g} s after {n} steps and "
                    f"{elapsed:.0f} s (its budget: {max_steps} steps or {max_seconds:g} s): the motion is too fast "
                    f"to resolve at rtol {rtol:g} over this duration; shorten the duration or lower the rates")
        y, t0 = solver.y, t1
    return OdeSolution(ts, pieces)


def dop853_solution(inertia, q0, omega0, duration: float, *, torque=None, rtol: float = 1e-13,
                    atol: float = 1e-15, max_steps: int | None = None):
    """High-accuracy reference: scipy DOP853 on ``[q, omega]`` from 0 to ``duration`` (rtol 1e-13, atol 1e-15),
    as a function ``t (n,) -> (q (n, 4) normalised, omega (n, 3))`` on its dense output; restarted at the torque's
    breakpoints (a field table's rows), where its time derivative jumps.

    The effort is bounded (:func:`solve_bounded`); a motion that plainly needs more than ``max_steps``
    (estimated from ``|omega0| duration``) is refused at once. Both raise :class:`ReferenceFailure`."""
    from scipy.integrate import DOP853

    I, q0, omega0, _ = _inputs(inertia, q0, omega0, [0.0])
    max_steps = SOLVER_MAX_STEPS if max_steps is None else max_steps
    turned = float(np.linalg.norm(omega0)) * float(duration)
    if _DOP853_STEPS_PER_RAD * turned > max_steps:
        raise ReferenceFailure(
            f"the DOP853 reference would need about {_DOP853_STEPS_PER_RAD * turned:.3g} steps for |omega0| T = "
            f"{turned:.3g} rad (its budget: {max_steps} steps): the motion is too fast to resolve at rtol {rtol:g} "
            f"over {float(duration):g} s; shorten the duration or lower the rates")
    breaks = torque.breakpoints(duration) if hasattr(torque, "breakpoints") else ()
    sol = solve_bounded(DOP853, rigid_body_rhs(I, torque), np.concatenate([q0, omega0]), duration, rtol=rtol,
                        atol=atol, what="the DOP853 reference", max_steps=max_steps, breakpoints=breaks)

    def at(t):
        y = sol(np.asarray(t, dtype=float)).T
        return y[:, :4] / np.linalg.norm(y[:, :4], axis=1, keepdims=True), y[:, 4:]

    return at


def dop853(inertia, q0, omega0, t, *, torque=None, rtol: float = 1e-13, atol: float = 1e-15):
    """:func:`dop853_solution` at the times ``t`` (ascending from 0). Returns ``q`` (n, 4), ``omega`` (n, 3)."""
    _, _, _, t = _inputs(inertia, q0, omega0, t)
    if np.any(np.diff(t) < 0) or t[0] < 0:
        raise ValueError("t: expected ascending times from 0")
    q, w = dop853_solution(inertia, q0, omega0, t[-1], torque=torque, rtol=rtol, atol=atol)(t)
    return continuous_quaternions(q), w


def own_period(inertia, q0, omega0, torque=None) -> float | None:
    """The period [s] of a body's own motion, where a closed form knows it (issue 36: a default duration shows it):
    torque free, the elliptic period of its rate (asymmetric), its body cone's (axisymmetric; the longer of it and
    the precession's), one turn (a steady rotation); a Lagrange top, its nutation's (its precession's when steady);
    an axisymmetric gyrostat, its body cone's. None at rest, or where no closed form applies."""
    I, q0, omega0, _ = _inputs(inertia, q0, omega0, [0.0])
    if exact_why_not(I, torque) is not None:
        return None
    if torque is not None and not getattr(torque, "conserves_momentum", False):  # Lagrange's top
        centre, force = torque.fixed_form()
        try:
            top = _top_state(I, q0, omega0, centre, force)
            roots = _top_cubic(top)
        except ReferenceFailure:
            return None
        span = roots.x2 - roots.x1
        if span > 0:
            lam = 0.5 * np.sqrt(top.beta * (roots.x3 - roots.x1))
            return float(2 * complete_k((roots.x3 - roots.x2) / (roots.x3 - roots.x1)) / lam)
        sin2 = top.one_minus_u0 * top.one_plus_u0
        return float(2 * np.pi * sin2 / abs(top.P)) if top.P else None  # psi' = P / sin^2 theta
    h = np.zeros(3) if torque is None else np.asarray(torque.h0, dtype=float)
    if not np.any(omega0) and not np.any(h):
        return None
    if np.any(h):  # the axisymmetric gyrostat: lam = ((C - A) w_e + |h|) / A
        e = h / np.linalg.norm(h)
        A, C = symmetric_moments(I, e)
        lam = ((C - A) * (e @ omega0) + np.linalg.norm(h)) / A
        H = np.linalg.norm(I @ omega0 + h)
        return float(2 * np.pi / max(abs(lam), H / A)) if lam or H else None
    J, V = principal_axes(I)
    w = V.T @ omega0
    Jw = J * w
    if np.linalg.norm(np.cross(w, Jw)) <= 1e-12 * np.linalg.norm(w) * np.linalg.norm(Jw):
        return float(2 * np.pi / np.linalg.norm(w))  # a steady rotation: one turn
    if J[1] - J[0] <= EQUAL_MOMENTS_RTOL * J[2] or J[2] - J[1] <= EQUAL_MOMENTS_RTOL * J[2]:
        axis = 2 if J[1] - J[0] <= EQUAL_MOMENTS_RTOL * J[2] else 0
        I_t = np.mean(np.delete(J, axis))
        lam = (J[axis] - I_t) * w[axis] / I_t
        cone = 2 * np.pi / abs(lam) if lam else np.inf
        return float(max(min(cone, 1e300), 2 * np.pi * I_t / np.linalg.norm(Jw)))
    return elliptic_period(I, omega0)


def elliptic_period(inertia, omega0) -> float:
    """Period [s] of the body rate of an asymmetric torque-free body (``4 K(m) / lam``); inf if steady."""
    J, V = principal_axes(validate_inertia(inertia))
    w = V.T @ np.asarray(omega0, float)
    E2, h2 = float(w @ (J * w)), float((J * w) @ (J * w))
    if h2 < E2 * J[1]:
        J = J[::-1]
    J1, J2, J3 = J
    lam = np.sqrt(abs((J3 - J2) * (h2 - E2 * J1) / (J1 * J2 * J3)))
    m = abs((J2 - J1) * (E2 * J3 - h2) / ((J3 - J2) * (h2 - E2 * J1)))
    return float(4 * ellipk(m) / lam) if lam > 0 else float("inf")


def exact_kind(torque) -> str:
    """Which closed form :func:`exact_reference` uses for ``torque``, in words."""
    if torque is None:
        return "torque-free closed form"
    return "axisymmetric gyrostat's closed form" if getattr(torque, "conserves_momentum", False) else \
        "heavy top's closed form (Lagrange's)"
