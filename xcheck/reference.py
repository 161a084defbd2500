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

import numpy as np
from scipy.special import ellipj, ellipk, ellipkinc

from . import rotations as rot
from .body import principal_axes, validate_inertia
from .trajectory import check_initial_state, continuous_quaternions

__all__ = ["exact_torque_free", "exact_reference", "exact_why_not", "exact_gyrostat", "gyrostat_why_not", "lagrange_top", "lagrange_why_not", "dop853", "dop853_solution", "rigid_body_rhs", "EQUAL_MOMENTS_RTOL",
           "ReferenceFailure", "solve_bounded"]

#: Principal moments closer than this (relative to the largest) are treated as equal (axisymmetry).
EQUAL_MOMENTS_RTOL = 1e-12
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
    angular momentum for the attitude, its precession angle by Gauss-Legendre quadrature."""
    E2 = float(np.dot(w0, J * w0))  # 2 x kinetic energy
    h2 = float(np.dot(J * w0, J * w0))  # |h|^2
    # the axis the body rate circulates about: the largest moment if h^2 > 2 E I2, else the smallest;
    # relabel it axis 3 with a proper rotation P (body comps = P @ relabelled comps)
    if h2 >= E2 * J[1]:
        P = np.eye(3)
    else:
        P = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])  # columns e3, -e2, e1; det +1
    qP = rot.dcm_to_quat(P)
    J = np.abs(P.T @ J)  # moments relabelled (P is a signed permutation)
    w = P.T @ w0
    q_start = rot.quat_mul(q0, qP)
    J1, J2, J3 = J
    A1 = np.sqrt(abs((E2 * J3 - h2) / (J1 * (J3 - J1))))
    A2 = np.sqrt(abs((E2 * J3 - h2) / (J2 * (J3 - J2))))
    A3 = np.sqrt(abs((h2 - E2 * J1) / (J3 * (J3 - J1))))
    lam = np.sqrt(abs((J3 - J2) * (h2 - E2 * J1) / (J1 * J2 * J3)))
    m = min(abs((J2 - J1) * (E2 * J3 - h2) / ((J3 - J2) * (h2 - E2 * J1))), 1.0)
    s3 = 1.0 if w[2] >= 0 else -1.0
    s2 = s3 * np.sign(J3 - J2)  # from Euler's equations: w2 = s2 A2 sn keeps I2 w2' = (I3 - I1) w3 w1
    tau0 = ellipkinc(np.arctan2(w[1] / (s2 * A2), w[0] / A1), m)

    def rates(tt):
        sn, cn, dn, _ = ellipj(tau0 + lam * tt, m)
        return np.stack([A1 * cn, s2 * A2 * sn, s3 * A3 * dn], axis=-1)

    h = np.sqrt(h2)

    def psi_dot(tt):  # seed-independent classic: h (J1 w1^2 + J2 w2^2) / ((J1 w1)^2 + (J2 w2)^2)
        r = rates(tt)
        num = J1 * r[..., 0] ** 2 + J2 * r[..., 1] ** 2
        den = (J1 * r[..., 0]) ** 2 + (J2 * r[..., 1]) ** 2
        return h * num / den

    omega = rates(t)
    psi = _cumulative_quadrature(psi_dot, t, _PANEL_TAU / lam)
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


def _cumulative_quadrature(f, t, max_panel):
    """``int_0^t f`` at each time of ``t`` (any order, any sign) by 10-point Gauss-Legendre on panels no
    longer than ``max_panel`` between consecutive knots (the requested times and 0)."""
    knots, inverse = np.unique(np.concatenate([[0.0], t]), return_inverse=True)
    lengths = np.diff(knots)
    counts = np.maximum(1, np.ceil(lengths / max_panel).astype(np.int64))
    if counts.sum() > _MAX_PANELS:
        raise ReferenceFailure(f"the exact reference would need {counts.sum():.3g} quadrature panels (at most "
                               f"{_MAX_PANELS}): the body turns too fast over this duration; shorten it or lower "
                               "the rates")
    # panels: each knot interval split into `counts` equal parts
    seg = np.repeat(np.arange(len(lengths)), counts)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(counts) - counts, counts)
    width = lengths[seg] / counts[seg]
    left = knots[seg] + k * width
    nodes = left[:, None] + 0.5 * width[:, None] * (_GL_NODES + 1.0)
    panel = 0.5 * width * (f(nodes) @ _GL_WEIGHTS)
    per_interval = np.bincount(seg, weights=panel, minlength=len(lengths))
    cumulative = np.concatenate([[0.0], np.cumsum(per_interval)])
    zero = np.searchsorted(knots, 0.0)
    return (cumulative - cumulative[zero])[inverse[1:]]


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
    axisymmetric body, to :data:`EQUAL_MOMENTS_RTOL` x 100 of its norm): the transverse and the axial moment."""
    I = np.asarray(inertia, dtype=float)
    e = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    C = e @ I @ e
    A = 0.5 * (np.trace(I) - C)
    if np.linalg.norm(I - A * np.eye(3) - (C - A) * np.outer(e, e)) > EQUAL_MOMENTS_RTOL * 1e2 * np.linalg.norm(I):
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
    u1 <= u <= u2 <= 1 <= u3, so ``u = u1 + (u2 - u1) sn^2(lam t + tau0, k)`` with ``lam = sqrt(beta (u3 - u1)) / 2``
    and ``k^2 = (u2 - u1)/(u3 - u1)``; ``psi' = (a - b u)/(1 - u^2)`` and ``phi' = L_3/C - u psi'`` are integrated by
    Gauss-Legendre quadrature on panels of at most a quarter of the elliptic argument. Returns ``q`` (n, 4),
    sign-continuous, and ``omega`` (n, 3), body frame. :class:`ReferenceFailure` when the axis comes within
    :data:`LAGRANGE_MIN_SIN2` of the vertical."""
    I, q0, omega0, t = _inputs(inertia, q0, omega0, t)
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
    psi0, theta0, phi0 = rot.quat_to_euler(qT, "313", warn=False)
    R = rot.quat_to_dcm(qT)
    u0 = float(np.clip(R[2, 2], -1.0, 1.0))
    Mgl = float(np.linalg.norm(F) * np.linalg.norm(c))
    L3 = C * wT[2]
    Lz = float((R @ (np.array([A, A, C]) * wT))[2])
    alpha = (A * (wT[0] ** 2 + wT[1] ** 2) + 2 * Mgl * u0) / A
    beta, a, b = 2 * Mgl / A, Lz / A, L3 / A

    def f(u):
        return (alpha - beta * u) * (1 - u * u) - (a - b * u) ** 2

    u1, u2, u3 = _top_roots(f, beta, alpha, a, b, u0)
    if 1 - max(abs(u1), abs(u2)) ** 2 < LAGRANGE_MIN_SIN2:
        raise ReferenceFailure(f"the exact heavy-top reference: the axis comes within {np.degrees(np.arccos(min(1.0, max(abs(u1), abs(u2))))):.3g} "
                               f"deg of the vertical, where its precession rate loses digits; use 'dop853'")
    lam = 0.5 * np.sqrt(beta * (u3 - u1))
    m = (u2 - u1) / (u3 - u1) if u3 > u1 else 0.0
    span = u2 - u1
    if span > 1e-14:
        s0 = np.sqrt(np.clip((u0 - u1) / span, 0.0, 1.0))
        tau0 = float(ellipkinc(np.arcsin(s0), m))
        theta_dot0 = wT[0] * np.cos(phi0) - wT[1] * np.sin(phi0)  # from the 3-1-3 rates
        if theta_dot0 > 0:  # u = cos theta falling: the elliptic argument runs the other way from u0
            tau0 = -tau0
    else:  # steady precession: no nutation
        tau0, span = 0.0, 0.0

    def u_of(tt):
        sn, cn, dn, _ = ellipj(lam * tt + tau0, m)
        return u1 + span * sn * sn, 2 * span * lam * sn * cn * dn

    def psi_dot(tt):
        u = u_of(tt)[0]
        return (a - b * u) / (1 - u * u)

    def phi_dot(tt):
        return L3 / C - u_of(tt)[0] * psi_dot(tt)

    panel = _PANEL_TAU / lam if lam > 0 else np.inf
    panel = min(panel, 0.05 * 2 * np.pi / max(abs(a) + abs(b) + abs(L3 / C), 1e-300))  # the spin's own turns
    psi = psi0 + _cumulative_quadrature(psi_dot, t, panel)
    phi = phi0 + _cumulative_quadrature(phi_dot, t, panel)
    u, u_dot = u_of(t)
    theta = np.arctan2(np.sqrt(np.maximum(0.0, 1 - u * u)), u)
    rates = np.stack([(a - b * u) / (1 - u * u), -u_dot / np.sin(theta), L3 / C - u * (a - b * u) / (1 - u * u)],
                     axis=-1)
    angles = np.stack([psi, theta, phi], axis=-1)
    q = rot.quat_mul(rot.quat_mul(qG, rot.euler_to_quat(angles, "313")), rot.quat_conj(qB))
    omega = rot.euler_rates_to_omega(angles, rates, "313") @ B.T
    return continuous_quaternions(q), omega


def _top_roots(f, beta, alpha, a, b, u0):
    """The cubic's roots u1 <= u0 <= u2 <= 1 <= u3: f(-1) and f(1) are -(a -+ b)^2 <= 0, f(u0) = u'^2 >= 0 and f
    grows without bound (beta > 0), so its three roots, in order, are these (a double root where the nutation
    vanishes: a complex pair there, by a hair); each polished by Newton's method on f."""
    def fp(u):
        return -beta * (1 - u * u) - 2 * u * (alpha - beta * u) + 2 * b * (a - b * u)

    def polish(u):
        for _ in range(8):
            d = fp(u)
            if d == 0 or f(u) == 0:
                break
            step = f(u) / d
            u -= step
            if abs(step) <= 1e-17:
                break
        return u

    u1, u2, u3 = np.sort(np.roots([beta, -(alpha + b * b), 2 * a * b - beta, alpha - a * a]).real)
    u1, u2 = min(polish(u1), u0), max(polish(u2), u0)
    return u1, u2, max(polish(u3), 1.0)


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
        wd = Iinv @ (tau - wxh)  # (np.cross costs ten times more on 3-vectors)
        return np.concatenate([qd, wd])

    return f


#: The effort bound of a scipy solver run: at most this many steps, and this many seconds of wall time.
SOLVER_MAX_STEPS = 100_000
SOLVER_MAX_SECONDS = 60.0
#: DOP853 at rtol 1e-13 takes 3.6-5.8 steps per radian turned on the bundled scenarios: a run whose
#: ``|omega0| T`` predicts more steps than the budget is refused before it starts.
_DOP853_STEPS_PER_RAD = 3.0


def solve_bounded(method, fun, y0, duration: float, *, rtol: float, atol: float, what: str,
                  max_steps: int | None = None, max_seconds: float | None = None, breakpoints=()):
    """scipy's ``method`` (an ``OdeSolver`` class) from 0 to ``duration`` with a bounded effort; returns the
    dense :class:`scipy.integrate.OdeSolution`. :class:`ReferenceFailure` (naming ``what``) when the solver
    fails, the state becomes non-finite, or the run takes more than ``max_steps`` steps or ``max_seconds``
    (default :data:`SOLVER_MAX_STEPS`, :data:`SOLVER_MAX_SECONDS`). ``breakpoints``: times in (0, duration)
    where ``fun`` is not smooth (a table's rows): the solver restarts at each, so that no step straddles one
    (an error estimate across a kink is no estimate; DOP853 rejected step after step there)."""
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
            if solver.t < duration and (len(pieces) >= max_steps or elapsed > max_seconds):
                raise ReferenceFailure(
                    f"{what} gave up at t = {solver.t:.6g} of {duration:g} s after {len(pieces)} steps and "
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
