"""Every integration scheme of the kernels, one section each: its stage derivative written as its seed writes it
(each citing its equation), its hooks before and after a step, how ``(q, omega)`` becomes its state and back, and
its ``declare(...)``; then the registry's compile-time constants (state size, first integrated component, scratch)."""

from __future__ import annotations

import numpy as np

from ... import rotations as rot
from ...trajectory import continuous_quaternions
from ._variant import ijit, jit, torque_eval, torque_needs_attitude
from .registry import OK, SCHEMES, SINGULAR, Scheme, declare, layout
from .helpers import GT_s, G_s, bjorck, cross, dcm_to_quat, dexpinv_minus, dot3, euler_quat, f2_kinematics, gibbs_quat, qmul, quat_exp, rigid_body_rates, rotate_about_axis_T


# ------------------------------------------------------------------------------------------------
# EULER: RK4 on Euler angles (seed 001 appendix A)
# ------------------------------------------------------------------------------------------------
EULER_STATE = layout(angles=3, w=3)
EULER_WORK = layout(tau=3, q=4, e=4, c1=3, c2=3, c3=3, tmp=3, r=3)


@ijit
def deriv_euler(t, y, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work):
    """RK4 on (Euler angles, w) as seed 001's ``cinversa_euler``, for any sequence: the angle rates are
    ``J^-1 w`` with ``w = J angle'``; J's columns are ``Rc^T Rb^T e_a``, ``Rc^T e_b``, ``e_c``."""
    S, W = EULER_STATE, EULER_WORK
    ang, w = y[S.angles], y[S.w]
    tau, q, e = work[W.tau], work[W.q], work[W.e]
    c1, c2, c3, tmp, r = work[W.c1], work[W.c2], work[W.c3], work[W.tmp], work[W.r]
    cb, sb = np.cos(ang[1]), np.sin(ang[1])
    cc, sc = np.cos(ang[2]), np.sin(ang[2])
    c3[0] = c3[1] = c3[2] = 0.0
    c3[axes[0]] = 1.0  # e_a
    rotate_about_axis_T(axes[1], cb, sb, c3, tmp)
    rotate_about_axis_T(axes[2], cc, sc, tmp, c1)
    c3[0] = c3[1] = c3[2] = 0.0
    c3[axes[1]] = 1.0  # e_b
    rotate_about_axis_T(axes[2], cc, sc, c3, c2)
    c3[0] = c3[1] = c3[2] = 0.0
    c3[axes[2]] = 1.0  # e_c
    # rows of J^-1: (c2 x c3, c3 x c1, c1 x c2) / det, det = c1 . (c2 x c3) = -sin(b) or +-cos(b)
    cross(c2, c3, r)
    det = dot3(c1, r)
    if abs(det) < sing_tol:
        return SINGULAR
    dy[0] = dot3(r, w) / det
    cross(c3, c1, r)
    dy[1] = dot3(r, w) / det
    cross(c1, c2, r)
    dy[2] = dot3(r, w) / det
    if torque_needs_attitude(tk, tP):
        euler_quat(axes, ang, q, e)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[S.w])
    return OK


def _enc_euler(q0, w0, seq):
    return np.concatenate([rot.quat_to_euler(q0, seq, warn=False), w0], axis=-1)


@jit
def positive_w(q):
    """``q`` with ``w >= 0`` (the sign xcheck.rotations returns), in place."""
    if q[0] < 0.0:
        for i in range(4):
            q[i] = -q[i]


@jit
def euler_rows_to_quat(y, axes, q, e):
    """The quaternions (``w >= 0``, as xcheck.rotations.euler_to_quat) of the Euler-angle rows of ``y``."""
    for r in range(y.shape[0]):
        euler_quat(axes, y[r, EULER_STATE.angles], q[r], e)
        positive_w(q[r])


def _dec_euler(y, seq):
    q = np.empty((len(y), 4))
    euler_rows_to_quat(np.ascontiguousarray(y), np.array(rot._check_seq(seq), dtype=np.int64), q, np.empty(4))
    return continuous_quaternions(q), y[:, EULER_STATE.w], {"euler": y[:, EULER_STATE.angles].copy()}


EULER = declare(Scheme("euler", state=EULER_STATE, deriv=deriv_euler, encode=_enc_euler, decode=_dec_euler,
                       work=EULER_WORK))


# ------------------------------------------------------------------------------------------------
# F1: seed 004 Formulation I (§2.3)
# ------------------------------------------------------------------------------------------------
F1_STATE = layout(p=4, pdot=4)
F1_WORK = layout(tau=3, w=3)


@ijit
def deriv_formulation1(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 Formulation I: ``[2 I' G; p^T] p'' = [t' - 4 G G'^T I' G p'; -p'^T p']`` (eq. 154)
    with ``G' = G(p')`` (G is linear in p) and ``w' = 2 G p'`` (eq. 140).

    The 4x4 matrix is ``diag(2 I', 1) [G; p^T]``, and ``[G; p^T][G; p^T]^T = |p|^2 I4`` for any p
    (``G G^T = |p|^2 I3``, ``G p = 0``, eq. 95 and 98), so the solve is exact in closed form:
    ``p'' = (G^T (1/2 I'^-1 r1) + p r2) / |p|^2``.
    """
    p = y[F1_STATE.p]
    tau, w = work[F1_WORK.tau], work[F1_WORK.w]
    e0, e1, e2, e3 = y[0], y[1], y[2], y[3]
    d0, d1, d2, d3 = y[4], y[5], y[6], y[7]
    g0, g1, g2 = G_s(e0, e1, e2, e3, d0, d1, d2, d3)  # G(p) p' (eq. 94)
    w[0] = 2.0 * g0  # eq. 140
    w[1] = 2.0 * g1
    w[2] = 2.0 * g2
    torque_eval(tk, tP, tT, t, p, w, tau)
    # r1 = t' - 4 G Gdot^T I' G p'
    v0 = I[0, 0] * g0 + I[0, 1] * g1 + I[0, 2] * g2
    v1 = I[1, 0] * g0 + I[1, 1] * g1 + I[1, 2] * g2
    v2 = I[2, 0] * g0 + I[2, 1] * g1 + I[2, 2] * g2
    u0, u1, u2, u3 = GT_s(d0, d1, d2, d3, v0, v1, v2)  # G(p')^T I' G p'
    r0, r1_, r2_ = G_s(e0, e1, e2, e3, u0, u1, u2, u3)
    r0 = tau[0] - 4.0 * r0
    r1_ = tau[1] - 4.0 * r1_
    r2_ = tau[2] - 4.0 * r2_
    r2 = -(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3)
    h0 = (Iinv[0, 0] * r0 + Iinv[0, 1] * r1_ + Iinv[0, 2] * r2_) * 0.5
    h1 = (Iinv[1, 0] * r0 + Iinv[1, 1] * r1_ + Iinv[1, 2] * r2_) * 0.5
    h2 = (Iinv[2, 0] * r0 + Iinv[2, 1] * r1_ + Iinv[2, 2] * r2_) * 0.5
    q0, q1, q2, q3 = GT_s(e0, e1, e2, e3, h0, h1, h2)  # G(p)^T (1/2 I'^-1 r1)
    pp = e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3
    dy[0] = d0
    dy[1] = d1
    dy[2] = d2
    dy[3] = d3
    inv_pp = 1.0 / pp
    dy[4] = (q0 + e0 * r2) * inv_pp
    dy[5] = (q1 + e1 * r2) * inv_pp
    dy[6] = (q2 + e2 * r2) * inv_pp
    dy[7] = (q3 + e3 * r2) * inv_pp
    return OK


@ijit
def project_formulation1(y):
    """Seed 004 eq. 155-156: ``p <- p/|p|``, ``p' <- p' - (p'^T p) p`` (one division, four products)."""
    inv_n = 1.0 / np.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3])
    for i in range(4):
        y[i] *= inv_n
    d = y[0] * y[4] + y[1] * y[5] + y[2] * y[6] + y[3] * y[7]
    for i in range(4):
        y[4 + i] -= d * y[i]


def _enc_f1(q0, w0, seq):
    return np.concatenate([q0, rot.quat_rate(q0, w0)], axis=-1)  # p'0 = 1/2 G(p0)^T w0 (eq. 162)


def _dec_f1(y, seq):
    p, pd = y[:, F1_STATE.p], y[:, F1_STATE.pdot]
    omega = 2 * rot.quat_mul(rot.quat_conj(p), pd)[:, 1:]  # w' = 2 G(p) p' (eq. 140)
    return p.copy(), omega, {}


F1 = declare(Scheme("formulation-1", state=F1_STATE, deriv=deriv_formulation1, after_step=project_formulation1,
                    encode=_enc_f1, decode=_dec_f1, work=F1_WORK))


# ------------------------------------------------------------------------------------------------
# F2: seed 004 Formulation II (§2.4)
# ------------------------------------------------------------------------------------------------
F2_STATE = layout(p=4, w=3)
F2_WORK = layout(tau=3)


@ijit
def deriv_formulation2(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 Formulation II: ``p' = 1/2 G(p)^T w'`` (eq. 162), ``w' = I'^-1 (t' - w' x I' w')`` (eq. 158)."""
    p, w = y[F2_STATE.p], y[F2_STATE.w]
    dy[0], dy[1], dy[2], dy[3] = f2_kinematics(y[0], y[1], y[2], y[3], y[4], y[5], y[6])
    rigid_body_rates(t, p, w, I, Iinv, tk, tP, tT, work[F2_WORK.tau], dy[F2_STATE.w])
    return OK


@ijit
def normalise_formulation2(y):
    """Seed 004 algorithm 163: ``p_out = p_1out / sqrt(p_1out^T p_1out)``."""
    n = np.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3])
    for i in range(4):
        y[i] /= n


def _enc_f2(q0, w0, seq):
    return np.concatenate([q0, w0], axis=-1)


def _dec_f2(y, seq):
    return y[:, F2_STATE.p].copy(), y[:, F2_STATE.w].copy(), {}


F2 = declare(Scheme("formulation-2", state=F2_STATE, deriv=deriv_formulation2, after_step=normalise_formulation2,
                    encode=_enc_f2, decode=_dec_f2, work=F2_WORK))


# ------------------------------------------------------------------------------------------------
# LIE: seed 004 §2.5, the Lie-group method on S3 with RK on so(3); CF4 on the same state
# ------------------------------------------------------------------------------------------------
#: The Lie-group state: the step's base attitude (held in the step), the so(3) increment u, the rate.
LIE_STATE = layout(p_n=4, u=3, w=3)
LIE_WORK = layout(tau=3, p=4, e=4)
#: CF4's scratch: LIE's derivative's, then the step's own (the stage's increment v, its exponential, stage 2's
#: attitude).
CF4_WORK = layout(tau=3, p=4, e=4, v=3, ev=4, p2=4)


@ijit
def deriv_lie(t, y, yhat, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 §2.5: ``u' = dexp^-1_{-u}(w)`` (eq. 166-167) on so(3), the attitude of a stage is
    ``p_n ∘ exp_S3(u)`` (eq. 170-171) and ``w' = f(p, w)``. ``yhat`` carries the u of the dexp argument:
    the same as ``y`` for RKMK4 (``lie-rkmk4``, order 4); the printed algorithm 172 uses 1/2 k1 in the
    third stage (``lie-thesis-172``), which measures order 2 (see tableau.THESIS_172_DEXP_A). At ``u = 0``
    (every stage of CF4) ``u' = w`` and the stage's attitude is ``p_n`` itself, exactly."""
    S, W = LIE_STATE, LIE_WORK
    u, w = y[S.u], y[S.w]
    dexpinv_minus(yhat[S.u], w, dy[S.u])
    tau, p, e = work[W.tau], work[W.p], work[W.e]
    if torque_needs_attitude(tk, tP):
        quat_exp(u, e)  # the stage's attitude p_n ∘ exp_S3(u) (eq. 171)
        qmul(y[S.p_n], e, p)
    rigid_body_rates(t, p, w, I, Iinv, tk, tP, tT, tau, dy[S.w])
    return OK


@ijit
def lie_update(y, work):
    """Seed 004 algorithm 172: ``p_out = p_0 ∘ exp_S3(u)``; the unit norm holds by construction."""
    e = work[LIE_WORK.e]
    quat_exp(y[LIE_STATE.u], e)
    qmul(y[LIE_STATE.p_n], e, y[LIE_STATE.p_n])
    y[4] = y[5] = y[6] = 0.0  # u


def _enc_local(q0, w0, seq):
    """A local-chart state ``q_ref(4), v(3) = 0, w(3)`` (:data:`LIE_STATE`, :data:`CHART_STATE`)."""
    return np.concatenate([q0, np.zeros_like(w0), w0], axis=-1)


def _dec_lie(y, seq):
    return y[:, LIE_STATE.p_n].copy(), y[:, LIE_STATE.w].copy(), {}


LIE = declare(Scheme("lie", state=LIE_STATE, held="p_n", deriv=deriv_lie, after_step=lie_update,
                     encode=_enc_local, decode=_dec_lie, work=LIE_WORK))
#: The commutator-free method of order 4 (:func:`cf4_step`) on the LIE state: its stages all have u = 0.
CF4 = declare(Scheme("lie-cf4", state=LIE_STATE, held="p_n", deriv=deriv_lie, step="cf4", encode=_enc_local,
                     decode=_dec_lie, work=CF4_WORK))


# ------------------------------------------------------------------------------------------------
# DCM: RK4 on R' = R [w x] with Björck-Bowie (seed 000)
# ------------------------------------------------------------------------------------------------
DCM_STATE = layout(R=9, w=3)  # R row-major
DCM_WORK = layout(tau=3, q=4, XtX=9, Y=9)  # (XtX, Y: Björck-Bowie's)


@ijit
def deriv_dcm(t, y, dy, I, Iinv, tk, tP, tT, work):
    """``R' = R [w x]`` (seed 000 eq. 1.7 for the body -> world matrix; seed 004 eq. 131)."""
    R, w = y[DCM_STATE.R], y[DCM_STATE.w]
    for r in range(3):
        x0, x1, x2 = R[3 * r], R[3 * r + 1], R[3 * r + 2]
        dy[3 * r] = x1 * w[2] - x2 * w[1]
        dy[3 * r + 1] = x2 * w[0] - x0 * w[2]
        dy[3 * r + 2] = x0 * w[1] - x1 * w[0]
    q = work[DCM_WORK.q]
    if torque_needs_attitude(tk, tP):
        dcm_to_quat(R, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, work[DCM_WORK.tau], dy[DCM_STATE.w])
    return OK


@jit
def orthonormalise_dcm(y, bjorck_tol, work):
    bjorck(y[DCM_STATE.R], bjorck_tol, work[DCM_WORK.XtX], work[DCM_WORK.Y])


def _enc_dcm(q0, w0, seq):
    R = rot.quat_to_dcm(q0)
    return np.concatenate([R.reshape(R.shape[:-2] + (9,)), w0], axis=-1)


@jit
def dcm_rows_to_quat(y, q, ortho):
    """Decode the DCM rows of ``y`` (n, 12): their quaternions (``w >= 0``, as xcheck.rotations.dcm_to_quat) and
    ``max |R^T R - I|``, in one compiled pass (numpy's batched 3x3 products cost more than the integration)."""
    for r in range(y.shape[0]):
        R = y[r, DCM_STATE.R]
        dcm_to_quat(R, q[r])
        positive_w(q[r])
        err = 0.0
        for i in range(3):
            for j in range(3):
                d = R[i] * R[j] + R[3 + i] * R[3 + j] + R[6 + i] * R[6 + j] - (1.0 if i == j else 0.0)
                err = max(err, abs(d))
        ortho[r] = err


def _dec_dcm(y, seq):
    q, ortho = np.empty((len(y), 4)), np.empty(len(y))
    dcm_rows_to_quat(np.ascontiguousarray(y), q, ortho)
    return continuous_quaternions(q), y[:, DCM_STATE.w].copy(), {"orthogonality": ortho}


DCM = declare(Scheme("dcm", state=DCM_STATE, deriv=deriv_dcm, after_step=orthonormalise_dcm, encode=_enc_dcm,
                     decode=_dec_dcm, work=DCM_WORK))


# ------------------------------------------------------------------------------------------------
# GIBBS and ROTVEC: global charts re-centred before their singularities (seed 000)
# ------------------------------------------------------------------------------------------------
#: A global chart's state: the reference attitude (held in the step), the chart's parameter v (the Gibbs vector g
#: or the rotation vector phi), the rate.
CHART_STATE = layout(q_ref=4, v=3, w=3)
CHART_WORK = layout(tau=3, q=4, e=4)


@ijit
def deriv_gibbs(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Gibbs-vector kinematics ``g' = 1/2 (I + [g x] + g g^T) w`` (seed 000 §1.4.2, with the skew-term sign
    of its own §1.4.1 DCM; see xcheck.rotations.gibbs_rate); attitude ``q_ref ⊗ q(g)``."""
    S, W = CHART_STATE, CHART_WORK
    g, w = y[S.v], y[S.w]
    gw = g[0] * w[0] + g[1] * w[1] + g[2] * w[2]
    dy[4] = 0.5 * (w[0] + (g[1] * w[2] - g[2] * w[1]) + g[0] * gw)
    dy[5] = 0.5 * (w[1] + (g[2] * w[0] - g[0] * w[2]) + g[1] * gw)
    dy[6] = 0.5 * (w[2] + (g[0] * w[1] - g[1] * w[0]) + g[2] * gw)
    tau, q, e = work[W.tau], work[W.q], work[W.e]
    if torque_needs_attitude(tk, tP):
        gibbs_quat(g, e)
        qmul(y[S.q_ref], e, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[S.w])
    return OK


@ijit
def deriv_rotvec(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Rotation-vector kinematics with the non-commutativity term (seed 000 §1.5.2); attitude ``q_ref ⊗ exp(phi)``."""
    S, W = CHART_STATE, CHART_WORK
    phi, w = y[S.v], y[S.w]
    dexpinv_minus(phi, w, dy[S.v])
    tau, q, e = work[W.tau], work[W.q], work[W.e]
    if torque_needs_attitude(tk, tP):
        quat_exp(phi, e)
        qmul(y[S.q_ref], e, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[S.w])
    return OK


@jit
def recentre(y, limit, to_quat, e):
    """Fold the local chart into the reference quaternion when its parameter exceeds ``limit``."""
    v = y[CHART_STATE.v]
    if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > limit * limit:
        if to_quat == 0:
            gibbs_quat(v, e)
        else:
            quat_exp(v, e)
        qmul(y[CHART_STATE.q_ref], e, y[CHART_STATE.q_ref])
        y[4] = y[5] = y[6] = 0.0  # v


@jit
def recentre_gibbs(y, work):
    recentre(y, 1.0, 0, work[CHART_WORK.e])  # |g| = tan(angle/2) > 1: beyond 90 deg from the reference


@jit
def recentre_rotvec(y, work):
    recentre(y, np.pi, 1, work[CHART_WORK.e])  # dexp^-1 is singular at |phi| = 2 pi


def _dec_local(to_quat):
    """Decoder of a local-chart state ``q_ref(4), v(3), w(3)``: attitude ``q_ref ⊗ to_quat(v)``."""
    def decode(y, seq):
        q = rot.quat_mul(y[:, CHART_STATE.q_ref], to_quat(y[:, CHART_STATE.v]))
        return continuous_quaternions(q), y[:, CHART_STATE.w].copy(), {}
    return decode


GIBBS = declare(Scheme("gibbs", state=CHART_STATE, held="q_ref", deriv=deriv_gibbs, before_step=recentre_gibbs,
                       encode=_enc_local, decode=_dec_local(rot.gibbs_to_quat), work=CHART_WORK))
ROTVEC = declare(Scheme("rotvec", state=CHART_STATE, held="q_ref", deriv=deriv_rotvec, before_step=recentre_rotvec,
                        encode=_enc_local, decode=_dec_local(rot.rotvec_to_quat), work=CHART_WORK))

# ------------------------------------------------------------------------------------------------
# MRP: the modified Rodrigues parameters, as Basilisk integrates its hub's attitude
# ------------------------------------------------------------------------------------------------
@jit
def mrp_quat(s, out):
    """The quaternion of MRP ``s`` (``w = (1 - |s|^2) / (1 + |s|^2)``, ``v = 2 s / (1 + |s|^2)``)."""
    s2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    n = 1.0 + s2
    out[0] = (1.0 - s2) / n
    out[1] = 2.0 * s[0] / n
    out[2] = 2.0 * s[1] / n
    out[3] = 2.0 * s[2] / n


MRP_STATE = layout(s=3, w=3)
MRP_WORK = layout(tau=3, q=4)


@ijit
def deriv_mrp(t, y, dy, I, Iinv, tk, tP, tT, work):
    """``s' = 1/4 ((1 - |s|^2) I + 2 [s x] + 2 s s^T) w`` (Schaub & Junkins; xcheck.rotations.mrp_rate), the
    kinematics Basilisk's hub integrates."""
    s, w = y[MRP_STATE.s], y[MRP_STATE.w]
    s2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    sw = s[0] * w[0] + s[1] * w[1] + s[2] * w[2]
    dy[0] = 0.25 * ((1.0 - s2) * w[0] + 2.0 * (s[1] * w[2] - s[2] * w[1]) + 2.0 * s[0] * sw)
    dy[1] = 0.25 * ((1.0 - s2) * w[1] + 2.0 * (s[2] * w[0] - s[0] * w[2]) + 2.0 * s[1] * sw)
    dy[2] = 0.25 * ((1.0 - s2) * w[2] + 2.0 * (s[0] * w[1] - s[1] * w[0]) + 2.0 * s[2] * sw)
    q = work[MRP_WORK.q]
    if torque_needs_attitude(tk, tP):
        mrp_quat(s, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, work[MRP_WORK.tau], dy[MRP_STATE.w])
    return OK


@jit
def shadow_mrp(y):
    """The shadow set ``-s / |s|^2`` when ``|s| > 1`` (the same attitude; Basilisk switches after each step)."""
    s2 = y[0] * y[0] + y[1] * y[1] + y[2] * y[2]
    if s2 > 1.0:
        y[0], y[1], y[2] = -y[0] / s2, -y[1] / s2, -y[2] / s2


def _enc_mrp(q0, w0, seq):
    return np.concatenate([rot.quat_to_mrp(q0), w0], axis=-1)  # the short set, |s| <= 1


def _dec_mrp(y, seq):
    return continuous_quaternions(rot.mrp_to_quat(y[:, MRP_STATE.s])), y[:, MRP_STATE.w].copy(), {}


MRP = declare(Scheme("mrp", state=MRP_STATE, deriv=deriv_mrp, after_step=shadow_mrp, encode=_enc_mrp,
                     decode=_dec_mrp, work=MRP_WORK))


# ------------------------------------------------------------------------------------------------
# LGVI: the Lie group variational integrator (Lee, Leok & McClamroch 2005), implicit: its step is its own
# ------------------------------------------------------------------------------------------------
LGVI_STATE = layout(p=4, w=3)
#: the step's scratch (:func:`xcheck.integrators.kernels.steps.lgvi_step`): the torques at the start, the end and
#: the end's next iterate, the body momentum, the implicit equation's left side, its Cayley vector, residual,
#: Jacobian (row-major) and Newton update, the step's rotation and the end's attitude, F^T (Pi + h/2 M), the end's
#: rate and a vector of scratch; the step's start, kept where it is taken as substeps, and the count of the steps so
#: taken and the most substeps one took (read after the run). Its first part is also Formulation II's derivative's
#: (the scheme's, never called in a step).
LGVI_WORK = layout(M0=3, M1=3, M2=3, Pi=3, g=3, f=3, G=3, jac=9, df=3, qf=4, qn=4, base=3, wn=3, tmp=3, start=7,
                   split=2)

LGVI = declare(Scheme("lgvi", state=LGVI_STATE, deriv=deriv_formulation2, step="lgvi", encode=_enc_f2,
                      decode=_dec_f2, work=LGVI_WORK))


# ------------------------------------------------------------------------------------------------
# SPLIT: torque kicks around the exact free flow (Celledoni, Fassò, Säfström & Zanna 2008): their own steps
# ------------------------------------------------------------------------------------------------
SPLIT_STATE = layout(p=4, w=3)
#: the steps' scratch (:func:`xcheck.integrators.kernels.steps.split_step`): Formulation II's derivative's first
#: (the scheme's, never called in a step); whether the principal frame is made, its scratch, axes and moments; the
#: AGM's ratios; the body momentum after the first kick and after the flow, the flow's rotation, the end's attitude,
#: the end's torque and its next iterate, the end's rate; the last step's end (valid, q, w, its body momentum) and
#: its torque (valid, t, value), which the next step starts from when nothing moved.
SPLIT_WORK = layout(tau=3, ready=1, A=9, V=9, J=3, ratios=16, Pi=3, Pe=3, dq=4, qn=4, M1=3, M2=3, wn=3, cached=1, cq=4,
                    cw=3, cP=3, ctorque=1, ct=1, cM=3)

SPLIT2 = declare(Scheme("split-2", state=SPLIT_STATE, deriv=deriv_formulation2, step="split2", encode=_enc_f2,
                        decode=_dec_f2, work=SPLIT_WORK))
SPLIT4 = declare(Scheme("split-4", state=SPLIT_STATE, deriv=deriv_formulation2, step="split4", encode=_enc_f2,
                        decode=_dec_f2, work=SPLIT_WORK))


#: The declarations' sizes by scheme id, read from the registry: compile-time constants of the shared loops (the
#: entry points name their scheme by its id, a literal).
STATE_SIZE = tuple(s.size for s in SCHEMES)
FIRST = tuple(s.first for s in SCHEMES)
WORK_SIZE = tuple(s.work_size for s in SCHEMES)
