"""The exact flow of the free rigid body, compiled: what the splitting methods (:func:`.steps.split_step`) put between
their torque kicks (Celledoni, Fassò, Säfström & Zanna 2008, "The exact computation of the free rigid body motion
and its use in splitting methods", SIAM J. Sci. Comput. 30; ACM TOMS Algorithm 903).

In the body's principal frame, relabelled so that the body momentum ``m`` circulates about axis 3 (the largest
moment when ``|m|^2 >= 2 T J2``, else the smallest), Euler's equation has the solution (Landau & Lifshitz §37)::

    m1 = a cn(lam t + v),   m2 = b sn(lam t + v),   m3 = s3 c dn(lam t + v)     (modulus k)

with ``a, b, c, lam, k`` from the two invariants, written as sums of terms of one sign (no cancellation but that
of the separatrix's own ``|m|^2 - 2 T J2``). The phase ``v`` never appears: ``sn v, cn v, dn v`` are read off
``m(0)`` and the addition theorems give ``m(t)`` from ``sn, cn, dn`` of ``lam t`` alone (no elliptic integral of
the first kind; the step's ``lam t`` is small, where the AGM is exact).

The attitude: with ``u = m/|m|`` and ``u0 = u(0)``, ``R(t) = R(0) Rot(u0, psi) G(u(t))``, ``G(u)`` the smallest
rotation taking ``u`` to ``u0`` (body components), keeps the world momentum ``R m`` fixed; its angle obeys::

    psi' = (2T/|m| + u0 . w) / (1 + u0 . u)

(derived from ``w = psi' u + (G^T G')^v``; regular while ``u`` stays off ``-u0``, which a step never reaches),
integrated by Gauss-Legendre, 4 points where the step turns the body by at most 0.05 rad, else 8 points on pieces
of at most 0.5 rad, where its error is below round-off (the integrand is analytic; measured against the closed form,
tests/test_split.py). Celledoni et al. compute the same angle from Legendre's integral of the third kind; the
quadrature needs no Carlson ``R_J`` in the compiled code."""

from __future__ import annotations

import numpy as np

from ._variant import jit

#: 8- and 4-point Gauss-Legendre nodes and weights on [0, 1].
_XI, _WI = np.polynomial.legendre.leggauss(8)
GL_NODES, GL_WEIGHTS = 0.5 * (1.0 + _XI), 0.5 * _WI
_XI, _WI = np.polynomial.legendre.leggauss(4)
GL4_NODES, GL4_WEIGHTS = 0.5 * (1.0 + _XI), 0.5 * _WI
#: The longest piece of a step the 8-point quadrature of the angle takes at once, in radians of the body's fastest
#: turn (its error ~ piece^16 / 1e15), and the longest the 4-point one takes (~ piece^8 / 1e7: 1e-17 at 0.05).
GL_PIECE, GL4_PIECE = 0.5, 0.05
#: The AGM's steps at most (it converges quadratically: 5-6 in double precision, ~10 next to a separatrix).
AGM_STEPS = 16
#: A step's budget: the angle's quadrature takes at most this many pieces, a step that turns the body by at most
#: MAX_TURN [rad] (3 ms of work); a longer one is refused (:func:`free_flow` returns False) instead of running for
#: as long as it would (issue 58: a thin rod's step once bounded its rate by |m| / J_min, 1.4e9 rad/s, 88 s a step).
MAX_PIECES = 4096
MAX_TURN = MAX_PIECES * GL_PIECE
#: The rate that sets the pieces is |m| / J_min (at most J_max / J_min times the body's largest over its motion: 3
#: for RAX-1, 2 for the gyroscope), but never more than this many times that largest rate.
RATE_MARGIN = 16.0


@jit
def agm(m, m1, ratios):
    """The arithmetic-geometric mean of ``(1, sqrt(m1))``: its ratios ``c_n / a_n`` into ``ratios`` and
    ``(their count, 2^N a_N)`` (Abramowitz & Stegun 16.4; ``m1 = 1 - m`` given apart, as
    :func:`xcheck.elliptic.jacobi`)."""
    a, b, c = 1.0, np.sqrt(m1), np.sqrt(m)
    n = 0
    while abs(c) > 1e-17 * a and n < AGM_STEPS:
        a, b, c = 0.5 * (a + b), np.sqrt(a * b), 0.5 * (a - b)
        ratios[n] = c / a
        n += 1
    return n, (2.0 ** n) * a


@jit
def sncndn(u, m1, n, scale, ratios):
    """``sn, cn, dn`` of ``u`` from :func:`agm`'s ratios (the descending back-substitution of A&S 16.4.3);
    ``dn = sqrt(cn^2 + m1 sn^2)`` without the cancellation of ``1 - m sn^2``; the separatrix (``m1 = 0``) by tanh."""
    if m1 == 0.0:
        c = 1.0 / np.cosh(u)
        return np.tanh(u), c, c
    phi = scale * u
    for i in range(n - 1, -1, -1):
        phi = 0.5 * (np.arcsin(ratios[i] * np.sin(phi)) + phi)
    sn, cn = np.sin(phi), np.cos(phi)
    return sn, cn, np.sqrt(cn * cn + m1 * sn * sn)


@jit
def principal_frame(I, A, V, J):
    """The principal moments ``J`` (ascending) and axes ``V`` (row-major 3x3, columns the axes in body components,
    ``det V = +1``) of the symmetric ``I`` by cyclic Jacobi rotations (``A`` scratch, 9). A diagonal ``I`` keeps its
    axes."""
    for i in range(3):
        for j in range(3):
            A[3 * i + j] = I[i, j]
            V[3 * i + j] = 1.0 if i == j else 0.0
    for _ in range(50):
        off = abs(A[1]) + abs(A[2]) + abs(A[5])
        if off == 0.0 or off <= 1e-300:
            break
        for p, r in ((0, 1), (0, 2), (1, 2)):
            apq = A[3 * p + r]
            if apq == 0.0:
                continue
            theta = (A[3 * r + r] - A[3 * p + p]) / (2.0 * apq)
            t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
            c = 1.0 / np.sqrt(t * t + 1.0)
            s = t * c
            for k in range(3):  # A <- A G (columns p, r)
                akp, akr = A[3 * k + p], A[3 * k + r]
                A[3 * k + p] = c * akp - s * akr
                A[3 * k + r] = s * akp + c * akr
            for k in range(3):  # A <- G^T A (rows p, r)
                apk, ark = A[3 * p + k], A[3 * r + k]
                A[3 * p + k] = c * apk - s * ark
                A[3 * r + k] = s * apk + c * ark
            A[3 * p + r] = A[3 * r + p] = 0.0
            for k in range(3):  # V <- V G
                vkp, vkr = V[3 * k + p], V[3 * k + r]
                V[3 * k + p] = c * vkp - s * vkr
                V[3 * k + r] = s * vkp + c * vkr
        if abs(A[1]) + abs(A[2]) + abs(A[5]) <= 1e-16 * (abs(A[0]) + abs(A[4]) + abs(A[8])):
            break
    for i in range(3):
        J[i] = A[4 * i]
    for i in range(2):  # ascending, by swaps that keep det V = +1 (a swap of columns and a sign)
        for j in range(2 - i):
            if J[j] > J[j + 1]:
                J[j], J[j + 1] = J[j + 1], J[j]
                for k in range(3):
                    V[3 * k + j], V[3 * k + j + 1] = V[3 * k + j + 1], -V[3 * k + j]


@jit
def _dot_v(V, col, x0, x1, x2):
    """Column ``col`` of ``V`` dotted with ``x``."""
    return V[col] * x0 + V[3 + col] * x1 + V[6 + col] * x2


@jit
def free_flow(m, h, V, J, ratios, m_out, dq):
    """The exact torque-free flow over ``h`` of the body momentum ``m`` (body components): ``m_out`` its end and
    ``dq`` the attitude's increment less the identity (body frame, ``q(h) = q(0) + q(0) ⊗ dq``: rounded relative to
    the turn, as ``m_out``). ``V, J`` the principal frame
    (:func:`principal_frame`); ``ratios`` scratch (:data:`AGM_STEPS`). See the module docstring. Returns False,
    leaving ``m_out`` and ``dq`` unset, for a step that turns the body by more than :data:`MAX_TURN`."""
    M2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2]
    if M2 == 0.0:
        dq[0], dq[1], dq[2], dq[3] = 0.0, 0.0, 0.0, 0.0
        m_out[0], m_out[1], m_out[2] = 0.0, 0.0, 0.0
        return True
    Mn = np.sqrt(M2)
    p0, p1, p2 = (V[0] * m[0] + V[3] * m[1] + V[6] * m[2], V[1] * m[0] + V[4] * m[1] + V[7] * m[2],
                  V[2] * m[0] + V[5] * m[1] + V[8] * m[2])  # principal components V^T m
    J1, J2, J3 = J[0], J[1], J[2]
    Z = p0 * p0 * (J1 - J2) / J1 + p2 * p2 * (J3 - J2) / J3  # |m|^2 - 2 T J2: which axis m circulates about
    flip = Z < 0.0
    if flip:  # relabel (e3, -e2, e1): a proper rotation, moments descending
        x0, x1, x2, K1, K2, K3, Z = p2, -p1, p0, J3, J2, J1, -Z
    else:
        x0, x1, x2, K1, K2, K3 = p0, p1, p2, J1, J2, J3
    D31, D32, D21 = K3 - K1, K3 - K2, K2 - K1  # all of one sign
    X = x0 * x0 * D31 / K1 + x1 * x1 * D32 / K2  # 2 T K3 - |m|^2
    Y = x1 * x1 * D21 / K2 + x2 * x2 * D31 / K3  # |m|^2 - 2 T K1
    two_T = x0 * x0 / K1 + x1 * x1 / K2 + x2 * x2 / K3
    if X == 0.0 or Y == 0.0 or D32 == 0.0:  # a steady spin about a principal axis (or a sphere): R(h) = R exp(h w)
        w0, w1, w2 = p0 / J1, p1 / J2, p2 / J3
        wb0, wb1, wb2 = (V[0] * w0 + V[1] * w1 + V[2] * w2, V[3] * w0 + V[4] * w1 + V[5] * w2,
                         V[6] * w0 + V[7] * w1 + V[8] * w2)
        half = 0.5 * h * np.sqrt(wb0 * wb0 + wb1 * wb1 + wb2 * wb2)
        s = 0.5 * h * (np.sin(half) / half if half != 0.0 else 1.0)
        sq = np.sin(0.5 * half)
        dq[0], dq[1], dq[2], dq[3] = -2.0 * sq * sq, s * wb0, s * wb1, s * wb2  # exp(h w / 2) - 1
        m_out[0], m_out[1], m_out[2] = m[0], m[1], m[2]
        return True
    a = np.sqrt(K1 * X / D31)
    b = np.sqrt(K2 * X / D32)
    c = np.sqrt(K3 * Y / D31)
    s3 = 1.0 if x2 >= 0.0 else -1.0
    lam = s3 * (1.0 if D32 > 0.0 else -1.0) * np.sqrt(D32 * Y / (K1 * K2 * K3))
    mk = D21 * X / (D32 * Y)  # k^2
    mk1 = abs(D31) * Z / (D32 * Y)  # 1 - k^2, from the separatrix's distance
    snv, cnv = x1 / b, x0 / a
    r = np.sqrt(snv * snv + cnv * cnv)
    snv, cnv = snv / r, cnv / r
    dnv = np.sqrt(cnv * cnv + mk1 * snv * snv)
    n, scale = agm(mk, mk1, ratios)
    # the angle: Gauss-Legendre on pieces of the step, as many as the body's fastest rate turns it by half radians, or
    # the polhode's own rate: the rate bounded by |m| / J_min, but at most RATE_MARGIN times the largest the motion
    # reaches (|(a/K1, b/K2, c/K3)|, the amplitudes of m's components): a thin body's |m| / J_min is 1e8 times that
    wmax = min(Mn / min(abs(K1), abs(K3)), RATE_MARGIN * np.sqrt((a / K1) ** 2 + (b / K2) ** 2 + (c / K3) ** 2))
    turn = abs(h) * max(wmax, abs(lam))
    if not turn <= MAX_TURN:
        return False
    short = turn <= GL4_PIECE
    pieces = 1 if short else max(1, int(np.ceil(turn / GL_PIECE)))
    piece = h / pieces
    psi = 0.0
    for k in range(pieces):
        acc = 0.0
        for j in range(4 if short else 8):
            node, weight = (GL4_NODES[j], GL4_WEIGHTS[j]) if short else (GL_NODES[j], GL_WEIGHTS[j])
            sn_u, cn_u, dn_u = sncndn(lam * (k + node) * piece, mk1, n, scale, ratios)
            d = cn_u * cn_u + sn_u * sn_u * dnv * dnv  # 1 - k^2 sn^2 u sn^2 v, a sum of terms >= 0
            y0 = a * (cn_u * cnv - sn_u * snv * dn_u * dnv) / d
            y1 = b * (sn_u * cnv * dnv + snv * cn_u * dn_u) / d
            y2 = s3 * c * (dn_u * dnv - mk * sn_u * snv * cn_u * cnv) / d
            u0w = (x0 * y0 / K1 + x1 * y1 / K2 + x2 * y2 / K3) / Mn
            u0u = (x0 * y0 + x1 * y1 + x2 * y2) / M2
            acc += weight * (two_T / Mn + u0w) / (1.0 + u0u)
        psi += acc * piece
    # the end as the start plus its increment, each term of which is O(lam h) (no difference of nearly equal numbers):
    # a step's rounding is then relative to what it changes, and a run's invariants drift by the path's length times
    # round-off, whatever the number of steps (as m(h) itself, they drifted 1e-16 a step, all one way)
    sn_u, cn_u, dn_u = sncndn(lam * h, mk1, n, scale, ratios)
    d = cn_u * cn_u + sn_u * sn_u * dnv * dnv
    s2 = sn_u * sn_u
    d0 = a * (cnv * s2 * (cn_u / (1.0 + cn_u) - dnv * dnv) - sn_u * snv * dn_u * dnv) / d  # a (cn(u+v) - cn v)
    d1 = b * (sn_u * cnv * dnv + snv * s2 * (cn_u * mk1 / (dn_u + cn_u) - dnv * dnv)) / d  # b (sn(u+v) - sn v)
    d2 = s3 * c * mk * (dnv * s2 * (snv * snv - 1.0 / (1.0 + dn_u)) - sn_u * snv * cn_u * cnv) / d  # c (dn(u+v) - dn v)
    if flip:
        e0, e1, e2 = d2, -d1, d0
    else:
        e0, e1, e2 = d0, d1, d2
    m_out[0] = m[0] + (V[0] * e0 + V[1] * e1 + V[2] * e2)
    m_out[1] = m[1] + (V[3] * e0 + V[4] * e1 + V[5] * e2)
    m_out[2] = m[2] + (V[6] * e0 + V[7] * e1 + V[8] * e2)
    # dq = Rot(u0, psi) ⊗ (the smallest rotation taking u1 to u0), body components, returned less the identity:
    # its scalar part's 1 - cos terms formed as squares of sines, so that q + q ⊗ (dq - 1) rounds relative to the turn
    u00, u01, u02 = m[0] / Mn, m[1] / Mn, m[2] / Mn
    n1 = np.sqrt(m_out[0] * m_out[0] + m_out[1] * m_out[1] + m_out[2] * m_out[2])
    u10, u11, u12 = m_out[0] / n1, m_out[1] / n1, m_out[2] / n1
    c1 = 1.0 + (u10 * u00 + u11 * u01 + u12 * u02)
    g1, g2, g3 = u11 * u02 - u12 * u01, u12 * u00 - u10 * u02, u10 * u01 - u11 * u00
    gv2 = g1 * g1 + g2 * g2 + g3 * g3
    gn = np.sqrt(c1 * c1 + gv2)
    g0m1 = -gv2 / (gn * (c1 + gn))  # c1 / gn - 1
    g1, g2, g3 = g1 / gn, g2 / gn, g3 / gn
    sq = np.sin(0.25 * psi)
    r0m1 = -2.0 * sq * sq  # cos(psi/2) - 1
    sp = np.sin(0.5 * psi)
    r1, r2, r3 = sp * u00, sp * u01, sp * u02
    r0, g0 = 1.0 + r0m1, 1.0 + g0m1
    dq[0] = r0m1 + g0m1 + r0m1 * g0m1 - (r1 * g1 + r2 * g2 + r3 * g3)
    dq[1] = r0 * g1 + r1 * g0 + r2 * g3 - r3 * g2
    dq[2] = r0 * g2 - r1 * g3 + r2 * g0 + r3 * g1
    dq[3] = r0 * g3 + r1 * g2 - r2 * g1 + r3 * g0
    return True
