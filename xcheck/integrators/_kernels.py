"""The integrators' hot loop: one stage-arithmetic function for every Butcher tableau, and each method's
stage derivative written as the seed writes it.

This module is compiled by numba (``cache=True``: compiled once per user and release into the folder of
:mod:`xcheck._jit`, then loaded in ~0.2 s) when the torque is one of xcheck's torque models
(:mod:`xcheck.fields`, plain data). The same source is loaded two more times under other module names
(:func:`xcheck.integrators._kernels_for`): ``..._kernels_inlined``, everything inlined for the batch path, and
``..._kernels_python``, with ``jit`` the identity, which runs in the interpreter for an arbitrary Python torque
callable: one code path per method, fast or general.

State layouts (``y``, at most ``MAX_STATE`` floats; ``q`` is [w, x, y, z] body -> world, ``w`` the body rate):

=========  ======================================  =============================================
method     y                                       seed
=========  ======================================  =============================================
EULER      angles(3), w(3)                         seed 001 appendix A (any of the 12 sequences)
F1         p(4), p'(4)                             seed 004 §2.3, eq. 150-157
F2         p(4), w(3)                              seed 004 §2.4, eq. 158-163
LIE        p_n(4), u(3), w(3)                      seed 004 §2.5, eq. 166-172 (u = 0 at each step)
DCM        R(9, row-major), w(3)                   seed 000 eq. 1.7, §1.7.1
GIBBS      q_ref(4), g(3), w(3)                    seed 000 §1.4.2 (chart re-centred when |g| > 1)
ROTVEC     q_ref(4), phi(3), w(3)                  seed 000 §1.5.2 (chart re-centred when |phi| > pi)
=========  ======================================  =============================================
"""

import numpy as np

PYTHON_MODE = __name__.endswith("_python")
INLINED = __name__.endswith("_inlined")

if PYTHON_MODE:  # the interpreted twin: same code, Python torque callables

    def jit(f):
        return f

    pjit = loop_jit = ijit = jit
    prange = range

    def torque_eval(kind, P, T, t, q, w, out):
        """``kind`` is the user's callable ``(t, q, omega) -> (3,)``; ``q`` is passed normalised."""
        qn = q / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        value = np.asarray(kind(t, qn, w.copy()), dtype=float)
        if value.shape != (3,):
            raise ValueError(f"torque: the callable returned shape {value.shape}; expected (3,) [N m], "
                             "the body-frame torque")
        out[:] = value

    def torque_needs_attitude(kind, P):
        return True

else:
    import warnings

    from numba.extending import overload

    from .. import fields
    from .._jit import numba  # numba with xcheck's cache folder (outside the installed package)

    # numba's pedantic SSA check misfires on IR-inlined code ("variable ... is not in scope"); harmless
    warnings.filterwarnings("ignore", category=numba.core.errors.NumbaIRAssumptionWarning)

    # The stage loop and `run` are always inlined into the per-method entry points at the end (that is
    # what makes the method a compile-time constant). Helpers and stage derivatives are compiled once
    # and called (quick to compile: the single-trajectory path) -- or, in the "_inlined" twin used by the
    # batch path, inlined too: ~25 s instead of ~2 s to compile a method (once), for 1.5-2.5x the speed.
    _inline = "always" if INLINED else "never"
    jit = numba.njit(cache=True, error_model="numpy", inline=_inline)
    ijit = numba.njit(cache=True, error_model="numpy", inline="always")
    loop_jit = numba.njit(cache=True, error_model="numpy")
    pjit = numba.njit(cache=True, parallel=True, error_model="numpy")
    prange = numba.prange
    if INLINED:
        torque_eval = numba.njit(error_model="numpy", inline="always")(fields.torque_eval.py_func)
        torque_needs_attitude = numba.njit(error_model="numpy", inline="always")(fields.torque_needs_attitude.py_func)
    else:
        torque_eval = fields.torque_eval
        torque_needs_attitude = fields.torque_needs_attitude

EULER, F1, F2, LIE, DCM, GIBBS, ROTVEC = 0, 1, 2, 3, 4, 5, 6
STATE_SIZE = (6, 8, 7, 10, 12, 10, 10)
# the first integrated component: the reference quaternion of the local-chart methods is constant in a step
FIRST = (0, 0, 0, 4, 0, 4, 4)
MAX_STATE = 12
OK, SINGULAR, NONFINITE = 0, 1, 2

# so(3) coefficient series threshold [rad] (as in xcheck.rotations)
SERIES_ANGLE = 0.1


# ------------------------------------------------------------------------------------------------
# small helpers (scalar code on short arrays)
# ------------------------------------------------------------------------------------------------
@jit
def qmul(a, b, out):
    """Hamilton product ``a ⊗ b`` (seed 004 eq. 34)."""
    w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z


@jit
def quat_exp(u, out):
    """``exp_S3(u) = (cos|u/2|, sin|u/2| u/|u|)`` (seed 004 eq. 170); series (no sqrt, sin or cos)
    for |u|/2 < 0.1, where the truncation error is below 1e-17."""
    a2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    h2 = 0.25 * a2
    if h2 < SERIES_ANGLE * SERIES_ANGLE:
        c = 1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0 * (1.0 - h2 / 56.0 * (1.0 - h2 / 90.0))))
        s = 0.5 * (1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0 * (1.0 - h2 / 72.0))))
    else:
        a = np.sqrt(a2)
        c = np.cos(0.5 * a)
        s = np.sin(0.5 * a) / a
    out[0] = c
    out[1] = s * u[0]
    out[2] = s * u[1]
    out[3] = s * u[2]


@jit
def dexpinv_minus(u, w, out):
    """``dexp^-1_{-u}(w) = (I + 1/2 u~ - (|u| cot(|u|/2) - 2)/(2|u|^2) u~^2) w`` (seed 004 eq. 167), which is
    also the rotation-vector kinematics of seed 000 §1.5.2; series for |u| < 0.1 (truncation < 1e-19)."""
    a2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    if a2 < SERIES_ANGLE * SERIES_ANGLE:
        c = 1.0 / 12.0 + a2 / 720.0 + a2 * a2 / 30240.0 + a2 * a2 * a2 / 1209600.0 + a2 * a2 * a2 * a2 / 47900160.0
    else:
        a = np.sqrt(a2)
        c = (1.0 - 0.5 * a * np.cos(0.5 * a) / np.sin(0.5 * a)) / a2
    ux = u[1] * w[2] - u[2] * w[1]
    uy = u[2] * w[0] - u[0] * w[2]
    uz = u[0] * w[1] - u[1] * w[0]
    uux = u[1] * uz - u[2] * uy
    uuy = u[2] * ux - u[0] * uz
    uuz = u[0] * uy - u[1] * ux
    out[0] = w[0] + 0.5 * ux + c * uux
    out[1] = w[1] + 0.5 * uy + c * uuy
    out[2] = w[2] + 0.5 * uz + c * uuz


@jit
def matvec(M, v, out):
    """``out = M @ v`` for 3x3 ``M`` (no BLAS call, no allocation)."""
    a = M[0, 0] * v[0] + M[0, 1] * v[1] + M[0, 2] * v[2]
    b = M[1, 0] * v[0] + M[1, 1] * v[1] + M[1, 2] * v[2]
    c = M[2, 0] * v[0] + M[2, 1] * v[1] + M[2, 2] * v[2]
    out[0] = a
    out[1] = b
    out[2] = c


@jit
def cross(a, b, out):
    x = a[1] * b[2] - a[2] * b[1]
    y = a[2] * b[0] - a[0] * b[2]
    z = a[0] * b[1] - a[1] * b[0]
    out[0] = x
    out[1] = y
    out[2] = z


@jit
def dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def euler_equation(I, Iinv, tau, w, out):
    """``w' = I^-1 (t' - w x I w)`` (seed 004 eq. 143/158; seed 001 eq. 81-84)."""
    h0 = I[0, 0] * w[0] + I[0, 1] * w[1] + I[0, 2] * w[2]
    h1 = I[1, 0] * w[0] + I[1, 1] * w[1] + I[1, 2] * w[2]
    h2 = I[2, 0] * w[0] + I[2, 1] * w[1] + I[2, 2] * w[2]
    r0 = tau[0] - (w[1] * h2 - w[2] * h1)
    r1 = tau[1] - (w[2] * h0 - w[0] * h2)
    r2 = tau[2] - (w[0] * h1 - w[1] * h0)
    out[0] = Iinv[0, 0] * r0 + Iinv[0, 1] * r1 + Iinv[0, 2] * r2
    out[1] = Iinv[1, 0] * r0 + Iinv[1, 1] * r1 + Iinv[1, 2] * r2
    out[2] = Iinv[2, 0] * r0 + Iinv[2, 1] * r1 + Iinv[2, 2] * r2


@jit
def G_times(p, v4, out):
    """``G(p) v`` with ``G = [-e, -e~ + e0 I]`` (seed 004 eq. 94), ``v`` of length 4."""
    e0, e1, e2, e3 = p[0], p[1], p[2], p[3]
    out[0] = -e1 * v4[0] + e0 * v4[1] + e3 * v4[2] - e2 * v4[3]
    out[1] = -e2 * v4[0] - e3 * v4[1] + e0 * v4[2] + e1 * v4[3]
    out[2] = -e3 * v4[0] + e2 * v4[1] - e1 * v4[2] + e0 * v4[3]


@jit
def GT_times(p, v3, out):
    """``G(p)^T v`` (seed 004 eq. 94), ``v`` of length 3."""
    e0, e1, e2, e3 = p[0], p[1], p[2], p[3]
    out[0] = -e1 * v3[0] - e2 * v3[1] - e3 * v3[2]
    out[1] = e0 * v3[0] - e3 * v3[1] + e2 * v3[2]
    out[2] = e3 * v3[0] + e0 * v3[1] - e1 * v3[2]
    out[3] = -e2 * v3[0] + e1 * v3[1] + e0 * v3[2]


@jit
def rotate_about_axis_T(axis, c, s, v, out):
    """``R_axis(angle)^T v`` for the elementary active rotation about body axis 0, 1 or 2, given
    ``c = cos(angle)``, ``s = sin(angle)``."""
    j = (axis + 1) % 3
    k = (axis + 2) % 3
    out[axis] = v[axis]
    out[j] = c * v[j] + s * v[k]
    out[k] = -s * v[j] + c * v[k]


@jit
def euler_quat(axes, angles, out, e):
    """Quaternion of intrinsic Euler angles ``q_a ⊗ q_b ⊗ q_c`` (xcheck.rotations.euler_to_quat);
    ``e`` is a work array of 4."""
    out[0] = 1.0
    out[1] = 0.0
    out[2] = 0.0
    out[3] = 0.0
    for n in range(3):
        e[0] = np.cos(0.5 * angles[n])
        e[1] = 0.0
        e[2] = 0.0
        e[3] = 0.0
        e[axes[n] + 1] = np.sin(0.5 * angles[n])
        qmul(out, e, out)


@jit
def dcm_to_quat(R, out):
    """Quaternion of a row-major DCM (Shepperd's method; xcheck.rotations.dcm_to_quat)."""
    tr = R[0] + R[4] + R[8]
    if tr >= R[0] and tr >= R[4] and tr >= R[8]:
        out[0] = 1.0 + tr
        out[1] = R[7] - R[5]
        out[2] = R[2] - R[6]
        out[3] = R[3] - R[1]
    elif R[0] >= R[4] and R[0] >= R[8]:
        out[0] = R[7] - R[5]
        out[1] = 1.0 + 2.0 * R[0] - tr
        out[2] = R[1] + R[3]
        out[3] = R[2] + R[6]
    elif R[4] >= R[8]:
        out[0] = R[2] - R[6]
        out[1] = R[1] + R[3]
        out[2] = 1.0 + 2.0 * R[4] - tr
        out[3] = R[5] + R[7]
    else:
        out[0] = R[3] - R[1]
        out[1] = R[2] + R[6]
        out[2] = R[5] + R[7]
        out[3] = 1.0 + 2.0 * R[8] - tr
    n = np.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
    for i in range(4):
        out[i] /= n


# ------------------------------------------------------------------------------------------------
# stage derivatives, one per method
# ------------------------------------------------------------------------------------------------
@jit
def deriv_euler(t, y, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work):
    """RK4 on (Euler angles, w) as seed 001's ``cinversa_euler``, for any sequence: the angle rates are
    ``J^-1 w`` with ``w = J angle'``; J's columns are ``Rc^T Rb^T e_a``, ``Rc^T e_b``, ``e_c``."""
    ang = y[0:3]
    w = y[3:6]
    tau, q, e = work[0:3], work[3:7], work[7:11]
    c1, c2, c3, tmp, r = work[11:14], work[14:17], work[17:20], work[20:23], work[23:26]
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
    torque_eval(tk, tP, tT, t, q, w, tau)
    euler_equation(I, Iinv, tau, w, dy[3:6])
    return OK


@jit
def deriv_formulation1(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 Formulation I: ``[2 I' G; p^T] p'' = [t' - 4 G G'^T I' G p'; -p'^T p']`` (eq. 154)
    with ``G' = G(p')`` (G is linear in p) and ``w' = 2 G p'`` (eq. 140).

    The 4x4 matrix is ``diag(2 I', 1) [G; p^T]``, and ``[G; p^T][G; p^T]^T = |p|^2 I4`` for any p
    (``G G^T = |p|^2 I3``, ``G p = 0``, eq. 95 and 98), so the solve is exact in closed form:
    ``p'' = (G^T (1/2 I'^-1 r1) + p r2) / |p|^2``.
    """
    p = y[0:4]
    pd = y[4:8]
    tau, w, Gpd, IGpd, r1, hIr1 = work[0:3], work[3:6], work[6:9], work[9:12], work[12:15], work[15:18]
    GdT, GT = work[18:22], work[22:26]
    G_times(p, pd, Gpd)
    for i in range(3):
        w[i] = 2.0 * Gpd[i]  # eq. 140
    torque_eval(tk, tP, tT, t, p, w, tau)
    # r1 = t' - 4 G Gdot^T I' G p'
    matvec(I, Gpd, IGpd)
    GT_times(pd, IGpd, GdT)  # G(p')^T I' G p'
    G_times(p, GdT, r1)
    for i in range(3):
        r1[i] = tau[i] - 4.0 * r1[i]
    r2 = -(pd[0] * pd[0] + pd[1] * pd[1] + pd[2] * pd[2] + pd[3] * pd[3])
    matvec(Iinv, r1, hIr1)
    for i in range(3):
        hIr1[i] *= 0.5
    GT_times(p, hIr1, GT)
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3]
    for i in range(4):
        dy[i] = pd[i]
        dy[4 + i] = (GT[i] + p[i] * r2) / pp
    return OK


@jit
def deriv_formulation2(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 Formulation II: ``p' = 1/2 G(p)^T w'`` (eq. 162), ``w' = I'^-1 (t' - w' x I' w')`` (eq. 158)."""
    p = y[0:4]
    w = y[4:7]
    GT_times(p, w, dy[0:4])
    for i in range(4):
        dy[i] *= 0.5
    tau = work[0:3]
    torque_eval(tk, tP, tT, t, p, w, tau)
    euler_equation(I, Iinv, tau, w, dy[4:7])
    return OK


@jit
def deriv_lie(t, y, yhat, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 §2.5: ``u' = dexp^-1_{-u}(w)`` (eq. 166-167) on so(3), the attitude of a stage is
    ``p_n ∘ exp_S3(u)`` (eq. 170-171) and ``w' = f(p, w)``. ``yhat`` carries the u of the dexp argument:
    the same as ``y`` for RKMK4 (``lie-rkmk4``, order 4); the printed algorithm 172 uses 1/2 k1 in the
    third stage (``lie-thesis-172``), which measures order 2 (see tableau.THESIS_172_DEXP_A)."""
    u = y[4:7]
    w = y[7:10]
    dexpinv_minus(yhat[4:7], w, dy[4:7])
    tau, p, e = work[0:3], work[3:7], work[7:11]
    if torque_needs_attitude(tk, tP):
        quat_exp(u, e)  # the stage's attitude p_n ∘ exp_S3(u) (eq. 171)
        qmul(y[0:4], e, p)
    torque_eval(tk, tP, tT, t, p, w, tau)
    euler_equation(I, Iinv, tau, w, dy[7:10])
    return OK


@jit
def deriv_dcm(t, y, dy, I, Iinv, tk, tP, tT, work):
    """``R' = R [w x]`` (seed 000 eq. 1.7 for the body -> world matrix; seed 004 eq. 131)."""
    R = y[0:9]
    w = y[9:12]
    for r in range(3):
        a, b, c = R[3 * r], R[3 * r + 1], R[3 * r + 2]
        dy[3 * r] = b * w[2] - c * w[1]
        dy[3 * r + 1] = c * w[0] - a * w[2]
        dy[3 * r + 2] = a * w[1] - b * w[0]
    tau, q = work[0:3], work[3:7]
    if torque_needs_attitude(tk, tP):
        dcm_to_quat(R, q)
    torque_eval(tk, tP, tT, t, q, w, tau)
    euler_equation(I, Iinv, tau, w, dy[9:12])
    return OK


@jit
def gibbs_quat(g, out):
    n = np.sqrt(1.0 + g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
    out[0] = 1.0 / n
    out[1] = g[0] / n
    out[2] = g[1] / n
    out[3] = g[2] / n


@jit
def deriv_gibbs(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Gibbs-vector kinematics ``g' = 1/2 (I + [g x] + g g^T) w`` (seed 000 §1.4.2, with the skew-term sign
    of its own §1.4.1 DCM; see xcheck.rotations.gibbs_rate); attitude ``q_ref ⊗ q(g)``."""
    g = y[4:7]
    w = y[7:10]
    gw = g[0] * w[0] + g[1] * w[1] + g[2] * w[2]
    dy[4] = 0.5 * (w[0] + (g[1] * w[2] - g[2] * w[1]) + g[0] * gw)
    dy[5] = 0.5 * (w[1] + (g[2] * w[0] - g[0] * w[2]) + g[1] * gw)
    dy[6] = 0.5 * (w[2] + (g[0] * w[1] - g[1] * w[0]) + g[2] * gw)
    tau, q, e = work[0:3], work[3:7], work[7:11]
    if torque_needs_attitude(tk, tP):
        gibbs_quat(g, e)
        qmul(y[0:4], e, q)
    torque_eval(tk, tP, tT, t, q, w, tau)
    euler_equation(I, Iinv, tau, w, dy[7:10])
    return OK


@jit
def deriv_rotvec(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Rotation-vector kinematics with the non-commutativity term (seed 000 §1.5.2); attitude ``q_ref ⊗ exp(phi)``."""
    phi = y[4:7]
    w = y[7:10]
    dexpinv_minus(phi, w, dy[4:7])
    tau, q, e = work[0:3], work[3:7], work[7:11]
    if torque_needs_attitude(tk, tP):
        quat_exp(phi, e)
        qmul(y[0:4], e, q)
    torque_eval(tk, tP, tT, t, q, w, tau)
    euler_equation(I, Iinv, tau, w, dy[7:10])
    return OK


def deriv(method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work):
    """The stage derivative ``dy = f(t, y)`` of ``method``; returns OK or SINGULAR.

    Compiled, ``method`` is a compile-time constant (each entry point below is one method), and the
    overload registered after this function keeps only that method's branch: each method compiles
    and optimises on its own."""
    if method == EULER:
        return deriv_euler(t, y, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work)
    if method == F1:
        return deriv_formulation1(t, y, dy, I, Iinv, tk, tP, tT, work)
    if method == F2:
        return deriv_formulation2(t, y, dy, I, Iinv, tk, tP, tT, work)
    if method == LIE:
        return deriv_lie(t, y, yhat, dy, I, Iinv, tk, tP, tT, work)
    if method == DCM:
        return deriv_dcm(t, y, dy, I, Iinv, tk, tP, tT, work)
    if method == GIBBS:
        return deriv_gibbs(t, y, dy, I, Iinv, tk, tP, tT, work)
    return deriv_rotvec(t, y, dy, I, Iinv, tk, tP, tT, work)


if not PYTHON_MODE:

    @overload(deriv, inline="always")
    def _deriv_for_method(method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work):
        if not isinstance(method, numba.types.IntegerLiteral):
            return None  # numba then retries with the literal method
        return {
            EULER: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_euler(
                t, y, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work),
            F1: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_formulation1(
                t, y, dy, I, Iinv, tk, tP, tT, work),
            F2: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_formulation2(
                t, y, dy, I, Iinv, tk, tP, tT, work),
            LIE: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_lie(
                t, y, yhat, dy, I, Iinv, tk, tP, tT, work),
            DCM: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_dcm(
                t, y, dy, I, Iinv, tk, tP, tT, work),
            GIBBS: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_gibbs(
                t, y, dy, I, Iinv, tk, tP, tT, work),
            ROTVEC: lambda method, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work: deriv_rotvec(
                t, y, dy, I, Iinv, tk, tP, tT, work),
        }[method.literal_value]


# ------------------------------------------------------------------------------------------------
# before and after a step: chart changes and projections (exact between steps: orders unaffected)
# ------------------------------------------------------------------------------------------------
@jit
def recentre(y, limit, to_quat, e):
    """Fold the local chart into the reference quaternion when its parameter exceeds ``limit``."""
    v = y[4:7]
    if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > limit * limit:
        if to_quat == 0:
            gibbs_quat(v, e)
        else:
            quat_exp(v, e)
        qmul(y[0:4], e, y[0:4])
        y[4] = y[5] = y[6] = 0.0


@jit
def recentre_gibbs(y, work):
    recentre(y, 1.0, 0, work[0:4])  # |g| = tan(angle/2) > 1: beyond 90 deg from the reference


@jit
def recentre_rotvec(y, work):
    recentre(y, np.pi, 1, work[0:4])  # dexp^-1 is singular at |phi| = 2 pi


def before_step(method, y, work):
    """Chart changes between steps (exact, so the order is unaffected)."""
    if method == GIBBS:
        recentre_gibbs(y, work)
    elif method == ROTVEC:
        recentre_rotvec(y, work)


@jit
def bjorck(R, tol, work):
    """Björck-Bowie orthogonalisation of a row-major 3x3 ``R`` in place (seed 000 §1.7.1):
    ``X <- 1.5 X - 0.5 X X^T X`` until ``|X^T X - I| <= tol`` (max-norm), at most 10 iterations."""
    XtX, Y = work[0:9], work[9:18]
    for _ in range(10):
        err = 0.0
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += R[3 * k + i] * R[3 * k + j]
                XtX[3 * i + j] = acc
                d = acc - (1.0 if i == j else 0.0)
                if abs(d) > err:
                    err = abs(d)
        if err <= tol:
            return
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += R[3 * i + k] * XtX[3 * k + j]
                Y[3 * i + j] = 1.5 * R[3 * i + j] - 0.5 * acc
        for i in range(9):
            R[i] = Y[i]


@jit
def project_formulation1(y):
    """Seed 004 eq. 155-156: ``p <- p/|p|``, ``p' <- p' - (p'^T p) p``."""
    n = np.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3])
    for i in range(4):
        y[i] /= n
    d = y[0] * y[4] + y[1] * y[5] + y[2] * y[6] + y[3] * y[7]
    for i in range(4):
        y[4 + i] -= d * y[i]


@jit
def normalise_formulation2(y):
    """Seed 004 algorithm 163: ``p_out = p_1out / sqrt(p_1out^T p_1out)``."""
    n = np.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3])
    for i in range(4):
        y[i] /= n


@jit
def lie_update(y, work):
    """Seed 004 algorithm 172: ``p_out = p_0 ∘ exp_S3(u)``; the unit norm holds by construction."""
    e = work[0:4]
    quat_exp(y[4:7], e)
    qmul(y[0:4], e, y[0:4])
    y[4] = y[5] = y[6] = 0.0


@jit
def orthonormalise_dcm(y, bjorck_tol, work):
    bjorck(y[0:9], bjorck_tol, work)


def after_step(method, y, bjorck_tol, work):
    """Projections after a step."""
    if method == F1:
        project_formulation1(y)
    elif method == F2:
        normalise_formulation2(y)
    elif method == LIE:
        lie_update(y, work)
    elif method == DCM:
        orthonormalise_dcm(y, bjorck_tol, work)


if not PYTHON_MODE:

    @overload(before_step, inline="always")
    def _before_step_for_method(method, y, work):
        if not isinstance(method, numba.types.IntegerLiteral):
            return None
        m = method.literal_value
        if m == GIBBS:
            return lambda method, y, work: recentre_gibbs(y, work)
        if m == ROTVEC:
            return lambda method, y, work: recentre_rotvec(y, work)
        return lambda method, y, work: None

    @overload(after_step, inline="always")
    def _after_step_for_method(method, y, bjorck_tol, work):
        if not isinstance(method, numba.types.IntegerLiteral):
            return None
        m = method.literal_value
        if m == F1:
            return lambda method, y, bjorck_tol, work: project_formulation1(y)
        if m == F2:
            return lambda method, y, bjorck_tol, work: normalise_formulation2(y)
        if m == LIE:
            return lambda method, y, bjorck_tol, work: lie_update(y, work)
        if m == DCM:
            return lambda method, y, bjorck_tol, work: orthonormalise_dcm(y, bjorck_tol, work)
        return lambda method, y, bjorck_tol, work: None


# ------------------------------------------------------------------------------------------------
# the stage arithmetic for every tableau, and the loops
# ------------------------------------------------------------------------------------------------
@ijit
def rk_step(method, A, b, c, Ahat, use_hat, t, y, h, m, K, Y, Yhat, I, Iinv, tk, tP, tT, axes, sing_tol, work):
    """One explicit Runge-Kutta step ``y <- y + h sum_i b_i K_i`` with ``K_i = f(t + c_i h, y + h sum_j A_ij K_j)``.

    ``Ahat`` (used when ``use_hat``) gives a second set of stage values passed to the derivative as
    ``yhat``: only the printed Lie algorithm 172 needs it. ``y`` is left unchanged if a stage fails.
    """
    s = b.shape[0]
    first = FIRST[method]
    for l in range(first):  # constant in the step (a reference quaternion)
        Y[l] = y[l]
        Yhat[l] = y[l]
    for i in range(s):
        for l in range(first, m):
            acc = 0.0
            for j in range(i):
                acc += A[i, j] * K[j, l]
            Y[l] = y[l] + h * acc
        if use_hat:
            for l in range(first, m):
                acc = 0.0
                for j in range(i):
                    acc += Ahat[i, j] * K[j, l]
                Yhat[l] = y[l] + h * acc
            status = deriv(method, t + c[i] * h, Y, Yhat, K[i], I, Iinv, tk, tP, tT, axes, sing_tol, work)
        else:
            status = deriv(method, t + c[i] * h, Y, Y, K[i], I, Iinv, tk, tP, tT, axes, sing_tol, work)
        if status != OK:
            return status
    for l in range(first, m):
        acc = 0.0
        for i in range(s):
            acc += b[i] * K[i, l]
        y[l] += h * acc
    return OK


@ijit
def run(method, args, y0, I, Iinv, out):
    """Integrate ``n`` steps (the last of length ``last_h``) from ``y0``; store ``y`` every ``save_every``
    steps and at the end into ``out`` (row 0 = ``y0``). Returns (steps done, status): on a singular or
    non-finite step the loop stops, and ``out``'s remaining rows hold the last good state.

    ``args = (A, b, c, Ahat, use_hat, dt, n, last_h, tk, tP, tT, axes, sing_tol, bjorck_tol, save_every)``.
    """
    A, b, c, Ahat, use_hat, dt, n, last_h, tk, tP, tT, axes, sing_tol, bjorck_tol, save_every = args
    m = STATE_SIZE[method]
    s = b.shape[0]
    K = np.zeros((s, m))
    Y = np.zeros(m)
    Yhat = np.zeros(m)
    work = np.zeros(32)
    y = y0[:m].copy()
    y_prev = y.copy()
    out[0, :m] = y
    row = 1
    for step in range(n):
        h = dt if step < n - 1 else last_h
        t = step * dt
        before_step(method, y, work)
        y_prev[:] = y
        status = rk_step(method, A, b, c, Ahat, use_hat, t, y, h, m, K, Y, Yhat, I, Iinv, tk, tP, tT, axes,
                         sing_tol, work)
        if status == OK:
            after_step(method, y, bjorck_tol, work)
            for l in range(m):
                if not np.isfinite(y[l]):
                    status = NONFINITE
        if status != OK:
            y[:] = y_prev
            for r in range(row, out.shape[0]):
                out[r, :m] = y
            return step, status
        if (step + 1) % save_every == 0 or step == n - 1:
            out[row, :m] = y
            row += 1
    return n, OK


@ijit
def run_batch(method, args, Y0, I, Iinv, out, steps_done, status):
    """:func:`run` for each row of ``Y0`` (N, m), in parallel threads; ``I``, ``Iinv`` are (N, 3, 3)."""
    for k in prange(Y0.shape[0]):
        nd, st = run(method, args, Y0[k], I[k], Iinv[k], out[k])
        steps_done[k] = nd
        status[k] = st


# ------------------------------------------------------------------------------------------------
# entry points, one per method and path: the method is a constant, so each compiles (lazily, once, then
# cached) with only its own stage derivative, optimised for it
# ------------------------------------------------------------------------------------------------
@loop_jit
def run_euler(args, y0, I, Iinv, out):
    return run(EULER, args, y0, I, Iinv, out)


@loop_jit
def run_f1(args, y0, I, Iinv, out):
    return run(F1, args, y0, I, Iinv, out)


@loop_jit
def run_f2(args, y0, I, Iinv, out):
    return run(F2, args, y0, I, Iinv, out)


@loop_jit
def run_lie(args, y0, I, Iinv, out):
    return run(LIE, args, y0, I, Iinv, out)


@loop_jit
def run_dcm(args, y0, I, Iinv, out):
    return run(DCM, args, y0, I, Iinv, out)


@loop_jit
def run_gibbs(args, y0, I, Iinv, out):
    return run(GIBBS, args, y0, I, Iinv, out)


@loop_jit
def run_rotvec(args, y0, I, Iinv, out):
    return run(ROTVEC, args, y0, I, Iinv, out)


@pjit
def batch_euler(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(EULER, args, Y0, I, Iinv, out, steps_done, status)


@pjit
def batch_f1(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(F1, args, Y0, I, Iinv, out, steps_done, status)


@pjit
def batch_f2(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(F2, args, Y0, I, Iinv, out, steps_done, status)


@pjit
def batch_lie(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(LIE, args, Y0, I, Iinv, out, steps_done, status)


@pjit
def batch_dcm(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(DCM, args, Y0, I, Iinv, out, steps_done, status)


@pjit
def batch_gibbs(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(GIBBS, args, Y0, I, Iinv, out, steps_done, status)


@pjit
def batch_rotvec(args, Y0, I, Iinv, out, steps_done, status):
    run_batch(ROTVEC, args, Y0, I, Iinv, out, steps_done, status)


RUN = (run_euler, run_f1, run_f2, run_lie, run_dcm, run_gibbs, run_rotvec)
BATCH = (batch_euler, batch_f1, batch_f2, batch_lie, batch_dcm, batch_gibbs, batch_rotvec)
