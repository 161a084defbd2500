"""Small helpers of the kernels: quaternion and so(3) arithmetic on short arrays and its scalar forms (``*_s``),
Euler's equation, the Euler-angle, DCM and Gibbs conversions. Every scheme and the lanes are written with them."""

from __future__ import annotations

import numpy as np

from ._variant import ijit, jit, torque_eval
from .registry import SERIES_ANGLE


# ------------------------------------------------------------------------------------------------
# small helpers (scalar code on short arrays)
# ------------------------------------------------------------------------------------------------
# Scalar forms (``*_s``): the same arithmetic on numbers instead of arrays, inlined where used. The array helpers
# below are written with them, and so are the batch's lanes (section LANES), which run them in loops over many
# bodies that the compiler turns into vector instructions: the same numbers either way.
@ijit
def qmul_s(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product ``a ⊗ b`` (seed 004 eq. 34) of quaternions given by their components."""
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@jit
def qmul(a, b, out):
    """Hamilton product ``a ⊗ b`` (seed 004 eq. 34)."""
    w, x, y, z = qmul_s(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z


@ijit
def exp_coefs_series(h2):
    """``(cos h, sin h / (2h))`` of the half angle ``h`` from ``h2 = h^2`` by their series (h < 0.1)."""
    c = 1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0 * (1.0 - h2 / 56.0 * (1.0 - h2 / 90.0))))
    s = 0.5 * (1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0 * (1.0 - h2 / 72.0))))
    return c, s


@ijit
def exp_coefs_trig(a2):
    """``(cos |u|/2, sin(|u|/2) / |u|)`` from ``a2 = |u|^2``."""
    a = np.sqrt(a2)
    return np.cos(0.5 * a), np.sin(0.5 * a) / a


@ijit
def dexpinv_coef_series(a2):
    """``(1 - (|u|/2) cot(|u|/2)) / |u|^2`` from ``a2 = |u|^2`` by its series (|u| < 0.1, truncation < 1e-19)."""
    return 1.0 / 12.0 + a2 / 720.0 + a2 * a2 / 30240.0 + a2 * a2 * a2 / 1209600.0 + a2 * a2 * a2 * a2 / 47900160.0


@ijit
def dexpinv_coef_trig(a2):
    a = np.sqrt(a2)
    return (1.0 - 0.5 * a * np.cos(0.5 * a) / np.sin(0.5 * a)) / a2


@ijit
def dexpinv_apply(u0, u1, u2, w0, w1, w2, c):
    """``(I + 1/2 u~ + c u~^2) w`` (seed 004 eq. 167 with its coefficient ``c``)."""
    ux = u1 * w2 - u2 * w1
    uy = u2 * w0 - u0 * w2
    uz = u0 * w1 - u1 * w0
    uux = u1 * uz - u2 * uy
    uuy = u2 * ux - u0 * uz
    uuz = u0 * uy - u1 * ux
    return w0 + 0.5 * ux + c * uux, w1 + 0.5 * uy + c * uuy, w2 + 0.5 * uz + c * uuz


@ijit
def euler_rates(i00, i01, i02, i10, i11, i12, i20, i21, i22, j00, j01, j02, j10, j11, j12, j20, j21, j22,
                t0, t1, t2, w0, w1, w2):
    """``w' = I^-1 (t' - w x I w)`` (seed 004 eq. 143/158) with I and I^-1 given by their entries."""
    h0 = i00 * w0 + i01 * w1 + i02 * w2
    h1 = i10 * w0 + i11 * w1 + i12 * w2
    h2 = i20 * w0 + i21 * w1 + i22 * w2
    r0 = t0 - (w1 * h2 - w2 * h1)
    r1 = t1 - (w2 * h0 - w0 * h2)
    r2 = t2 - (w0 * h1 - w1 * h0)
    return (j00 * r0 + j01 * r1 + j02 * r2, j10 * r0 + j11 * r1 + j12 * r2, j20 * r0 + j21 * r1 + j22 * r2)


@ijit
def G_s(e0, e1, e2, e3, v0, v1, v2, v3):
    """``G(p) v`` with ``G = [-e, -e~ + e0 I]`` (seed 004 eq. 94), ``v`` of length 4."""
    return (-e1 * v0 + e0 * v1 + e3 * v2 - e2 * v3,
            -e2 * v0 - e3 * v1 + e0 * v2 + e1 * v3,
            -e3 * v0 + e2 * v1 - e1 * v2 + e0 * v3)


@ijit
def GT_s(e0, e1, e2, e3, v0, v1, v2):
    """``G(p)^T v`` (seed 004 eq. 94), ``v`` of length 3."""
    return (-e1 * v0 - e2 * v1 - e3 * v2, e0 * v0 - e3 * v1 + e2 * v2,
            e3 * v0 + e0 * v1 - e1 * v2, -e2 * v0 + e1 * v1 + e0 * v2)


@ijit
def f2_kinematics(e0, e1, e2, e3, w0, w1, w2):
    """``p' = 1/2 G(p)^T w'`` (seed 004 eq. 162, G of eq. 94)."""
    a0, a1, a2, a3 = GT_s(e0, e1, e2, e3, w0, w1, w2)
    return a0 * 0.5, a1 * 0.5, a2 * 0.5, a3 * 0.5


@jit
def quat_exp(u, out):
    """``exp_S3(u) = (cos|u/2|, sin|u/2| u/|u|)`` (seed 004 eq. 170); series (no sqrt, sin or cos)
    for |u|/2 < 0.1, where the truncation error is below 1e-17."""
    a2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    h2 = 0.25 * a2
    if h2 < SERIES_ANGLE * SERIES_ANGLE:
        c, s = exp_coefs_series(h2)
    else:
        c, s = exp_coefs_trig(a2)
    out[0] = c
    out[1] = s * u[0]
    out[2] = s * u[1]
    out[3] = s * u[2]


@jit
def dexpinv_minus(u, w, out):
    """``dexp^-1_{-u}(w) = (I + 1/2 u~ - (|u| cot(|u|/2) - 2)/(2|u|^2) u~^2) w`` (seed 004 eq. 167), which is
    also the rotation-vector kinematics of seed 000 §1.5.2; series for |u| < 0.1 (truncation < 1e-19)."""
    a2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    c = dexpinv_coef_series(a2) if a2 < SERIES_ANGLE * SERIES_ANGLE else dexpinv_coef_trig(a2)
    out[0], out[1], out[2] = dexpinv_apply(u[0], u[1], u[2], w[0], w[1], w[2], c)


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


@ijit
def euler_equation(I, Iinv, tau, w, out):
    """``w' = I^-1 (t' - w x I w)`` (seed 004 eq. 143/158; seed 001 eq. 81-84)."""
    out[0], out[1], out[2] = euler_rates(I[0, 0], I[0, 1], I[0, 2], I[1, 0], I[1, 1], I[1, 2], I[2, 0], I[2, 1], I[2, 2],
                                         Iinv[0, 0], Iinv[0, 1], Iinv[0, 2], Iinv[1, 0], Iinv[1, 1], Iinv[1, 2],
                                         Iinv[2, 0], Iinv[2, 1], Iinv[2, 2], tau[0], tau[1], tau[2], w[0], w[1], w[2])


@ijit
def rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dw):
    """Every scheme's tail: the torque at the stage (``q`` its attitude, ``w`` its rate) and Euler's equation,
    ``dw = I^-1 (tau - w x I w)`` (seed 004 eq. 158); ``tau`` is scratch (the torque, left there)."""
    torque_eval(tk, tP, tT, t, q, w, tau)
    euler_equation(I, Iinv, tau, w, dw)


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


@jit
def bjorck(R, tol, XtX, Y):
    """Björck-Bowie orthogonalisation of a row-major 3x3 ``R`` in place (seed 000 §1.7.1):
    ``X <- 1.5 X - 0.5 X X^T X`` until ``|X^T X - I| <= tol`` (max-norm), at most 10 iterations; ``XtX`` and ``Y``
    are 9 floats of scratch each."""
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
def gibbs_quat(g, out):
    n = np.sqrt(1.0 + g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
    out[0] = 1.0 / n
    out[1] = g[0] / n
    out[2] = g[1] / n
    out[3] = g[2] / n
