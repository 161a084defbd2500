"""The integrators' hot loop: every integration scheme as one declaration, one stage loop for every Butcher
tableau, and each scheme's stage derivative written as the seed writes it.

A *scheme* (:class:`Scheme`, registered with :func:`declare`) is everything the kernels need to know about a
method: its state layout (size, the first integrated component), its stage derivative, optional hooks before
and after a step (chart changes, projections), the kind of step (the tableau stage loop, or the commutator-free
step), the scratch space it uses, and how ``(q, omega)`` become its state and back (encode, decode).
:data:`xcheck.integrators.METHODS` names the schemes and gives each its tableau, order and seed. Adding a method
with a new state layout is its section below, ending in ``declare(...)``, one ``METHODS`` entry and the
README's table; a method on an existing scheme with another tableau is one ``METHODS`` entry.

States (``y``; ``q`` is [w, x, y, z] body -> world, ``w`` the body rate):

===========  ======================================  =============================================
scheme       y                                       seed
===========  ======================================  =============================================
EULER        angles(3), w(3)                         seed 001 appendix A (any of the 12 sequences)
F1           p(4), p'(4)                             seed 004 §2.3, eq. 150-157
F2           p(4), w(3)                              seed 004 §2.4, eq. 158-163
LIE          p_n(4), u(3), w(3)                      seed 004 §2.5, eq. 166-172 (u = 0 at each step)
CF4          p_n(4), u(3) = 0, w(3)                  commutator-free Lie group method of order 4
DCM          R(9, row-major), w(3)                   seed 000 eq. 1.7, §1.7.1
GIBBS        q_ref(4), g(3), w(3)                    seed 000 §1.4.2 (chart re-centred when |g| > 1)
ROTVEC       q_ref(4), phi(3), w(3)                  seed 000 §1.5.2 (chart re-centred when |phi| > pi)
MRP          s(3), w(3)                              Schaub & Junkins (Basilisk's attitude: shadow set
                                                     when |s| > 1 after each step)
===========  ======================================  =============================================

How it is fast: numba compiles it (``cache=True``: once per user and release, into the folder of
:mod:`xcheck._jit`; then loaded in ~0.2 s). Each scheme has two entry points made from the registry
(:func:`_entry_points`: ``run_<name>``, ``many_<name>``) in which the scheme is a compile-time constant and
its step function is named, and the dispatchers (:func:`deriv`, the hooks) are overloads that keep only that
scheme's code: each scheme compiles and is cached on its own. Inside one step:

- nothing allocates and nothing counts references: the loop and its helpers are compiled without numba's
  runtime (``_nrt=False``), the scratch arrays come from the caller (:func:`scratch`). A slice such as
  ``work[0:3]`` is then a free view; with the runtime, each one cost an atomic reference count, and the
  single-trajectory step took 1.1-2.1 us instead of 0.14-0.5 us;
- the stage loop, the stage derivatives, the hooks, Euler's equation and the torque's dispatch are inlined
  (``ijit``: a call passes ~7 machine words per array); the small kinematic helpers and the field
  evaluators (:func:`xcheck.fields.kernel.magnetic_torque`) stay calls, compiled once (``jit``): inlining
  them too bought < 5 % for 1-2 s more compile per scheme;
- a batch is the same compiled single-trajectory loop called for each row in parallel threads, each row
  with its own scratch: one loop, one compile; for Formulation II and the Lie-group method, blocks of bodies in
  lockstep (section LANES), the same scalar arithmetic in loops over the bodies that become vector
  instructions (5x the body-steps a second, the same numbers).

Kernel arguments are one named record (:class:`~xcheck.integrators.kernel_args.KernelArgs`), unpacked once
per run; derivatives and hooks take plain arguments.

Variants: :func:`xcheck.integrators._kernels_for` loads this same source under another module name with
``VARIANT = "python"`` set before it runs: ``jit`` is then the identity, and the same code is interpreted for
a Python torque callable. One code path per method, fast or general.
"""

import inspect
from dataclasses import dataclass

import numpy as np

from .. import rotations as rot
from ..trajectory import continuous_quaternions
from .tableau import RK4

#: Which variant this module is: set by the loader before the module runs (``_kernels_for``); the module
#: imported normally is the compiled one.
VARIANT = globals().get("VARIANT", "compiled")
if VARIANT not in ("compiled", "python"):
    raise ImportError(f"xcheck.integrators._kernels: unknown variant {VARIANT!r}")
PYTHON_MODE = VARIANT == "python"

if PYTHON_MODE:  # the interpreted twin: same code, Python torque callables

    def jit(f):
        return f

    pjit = ijit = jit_nogil = jit
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
    from .._jit import (
        numba,  # numba with xcheck's cache folder (outside the installed package)
    )

    # numba's pedantic SSA check misfires on IR-inlined code ("variable ... is not in scope"); harmless
    warnings.filterwarnings("ignore", category=numba.core.errors.NumbaIRAssumptionWarning)

    # jit: a helper compiled once and called; ijit: inlined where it is used (see the module docstring).
    # Neither uses numba's runtime: no allocation, no reference counts (numba refuses code that would).
    jit = numba.njit(cache=True, error_model="numpy", _nrt=False)
    ijit = numba.njit(cache=True, error_model="numpy", inline="always", _nrt=False)
    pjit = numba.njit(cache=True, parallel=True, error_model="numpy")
    jit_nogil = numba.njit(cache=True, error_model="numpy", _nrt=False, nogil=True)
    prange = numba.prange
    torque_eval = fields.torque_eval  # inlined (its evaluators are calls)
    torque_needs_attitude = fields.torque_needs_attitude

OK, SINGULAR, NONFINITE = 0, 1, 2

# so(3) coefficient series threshold [rad] (as in xcheck.rotations)
SERIES_ANGLE = 0.1


# ------------------------------------------------------------------------------------------------
# the registry of schemes
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scheme:
    """One integration scheme (see the module docstring).

    ``deriv(t, y, dy, ...) -> OK | SINGULAR`` writes the stage derivative of ``y`` into ``dy``; it names the
    inputs it needs among :data:`DERIV_ARGS` (``yhat``: the stage values of the dexp argument, only the printed
    algorithm 172 differs; ``tk, tP, tT`` the torque model; ``axes``, ``sing_tol`` for Euler angles; ``work``).
    ``before_step`` and ``after_step`` (inputs among :data:`HOOK_ARGS`) change ``y`` between steps, exactly (the order
    is unaffected); ``step`` is ``"rk"`` (the stage loop generated for the method's tableau, :func:`rk_step_for`) or
    ``"cf4"`` (:func:`cf4_step`);
    ``first`` components of ``y`` are constant within a step (a reference quaternion); ``work`` floats of
    scratch. ``encode(q0 (..., 4), w0 (..., 3), seq) -> y0 (..., size)`` and
    ``decode(y (n, size), seq) -> (q, omega, extras)`` are plain Python."""

    name: str
    size: int
    deriv: object
    encode: object
    decode: object
    first: int = 0
    before_step: object = None
    after_step: object = None
    step: str = "rk"
    work: int = 0


SCHEMES: list = []


def declare(scheme: Scheme) -> int:
    """Register ``scheme``; returns its id (the compile-time constant of the entry points)."""
    if scheme.step not in ("rk", "cf4"):
        raise ValueError(f"{scheme.name}: unknown step {scheme.step!r}")
    SCHEMES.append(scheme)
    return len(SCHEMES) - 1


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
def gibbs_quat(g, out):
    n = np.sqrt(1.0 + g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
    out[0] = 1.0 / n
    out[1] = g[0] / n
    out[2] = g[1] / n
    out[3] = g[2] / n


# ------------------------------------------------------------------------------------------------
# EULER: RK4 on Euler angles (seed 001 appendix A)
# ------------------------------------------------------------------------------------------------
@ijit
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
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[3:6])
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
        euler_quat(axes, y[r, 0:3], q[r], e)
        positive_w(q[r])


def _dec_euler(y, seq):
    q = np.empty((len(y), 4))
    euler_rows_to_quat(np.ascontiguousarray(y), np.array(rot._check_seq(seq), dtype=np.int64), q, np.empty(4))
    return continuous_quaternions(q), y[:, 3:6], {"euler": y[:, 0:3].copy()}


EULER = declare(Scheme("euler", size=6, deriv=deriv_euler, encode=_enc_euler, decode=_dec_euler, work=26))


# ------------------------------------------------------------------------------------------------
# F1: seed 004 Formulation I (§2.3)
# ------------------------------------------------------------------------------------------------
@ijit
def deriv_formulation1(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 Formulation I: ``[2 I' G; p^T] p'' = [t' - 4 G G'^T I' G p'; -p'^T p']`` (eq. 154)
    with ``G' = G(p')`` (G is linear in p) and ``w' = 2 G p'`` (eq. 140).

    The 4x4 matrix is ``diag(2 I', 1) [G; p^T]``, and ``[G; p^T][G; p^T]^T = |p|^2 I4`` for any p
    (``G G^T = |p|^2 I3``, ``G p = 0``, eq. 95 and 98), so the solve is exact in closed form:
    ``p'' = (G^T (1/2 I'^-1 r1) + p r2) / |p|^2``.
    """
    p = y[0:4]
    tau, w = work[0:3], work[3:6]
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
    p, pd = y[:, 0:4], y[:, 4:8]
    omega = 2 * rot.quat_mul(rot.quat_conj(p), pd)[:, 1:]  # w' = 2 G(p) p' (eq. 140)
    return p.copy(), omega, {}


F1 = declare(Scheme("formulation-1", size=8, deriv=deriv_formulation1, after_step=project_formulation1,
                    encode=_enc_f1, decode=_dec_f1, work=26))


# ------------------------------------------------------------------------------------------------
# F2: seed 004 Formulation II (§2.4)
# ------------------------------------------------------------------------------------------------
@ijit
def deriv_formulation2(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 Formulation II: ``p' = 1/2 G(p)^T w'`` (eq. 162), ``w' = I'^-1 (t' - w' x I' w')`` (eq. 158)."""
    p = y[0:4]
    w = y[4:7]
    dy[0], dy[1], dy[2], dy[3] = f2_kinematics(y[0], y[1], y[2], y[3], y[4], y[5], y[6])
    tau = work[0:3]
    rigid_body_rates(t, p, w, I, Iinv, tk, tP, tT, tau, dy[4:7])
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
    return y[:, 0:4].copy(), y[:, 4:7].copy(), {}


F2 = declare(Scheme("formulation-2", size=7, deriv=deriv_formulation2, after_step=normalise_formulation2,
                    encode=_enc_f2, decode=_dec_f2, work=3))


# ------------------------------------------------------------------------------------------------
# LIE: seed 004 §2.5, the Lie-group method on S3 with RK on so(3); CF4 on the same state
# ------------------------------------------------------------------------------------------------
@ijit
def deriv_lie(t, y, yhat, dy, I, Iinv, tk, tP, tT, work):
    """Seed 004 §2.5: ``u' = dexp^-1_{-u}(w)`` (eq. 166-167) on so(3), the attitude of a stage is
    ``p_n ∘ exp_S3(u)`` (eq. 170-171) and ``w' = f(p, w)``. ``yhat`` carries the u of the dexp argument:
    the same as ``y`` for RKMK4 (``lie-rkmk4``, order 4); the printed algorithm 172 uses 1/2 k1 in the
    third stage (``lie-thesis-172``), which measures order 2 (see tableau.THESIS_172_DEXP_A). At ``u = 0``
    (every stage of CF4) ``u' = w`` and the stage's attitude is ``p_n`` itself, exactly."""
    u = y[4:7]
    w = y[7:10]
    dexpinv_minus(yhat[4:7], w, dy[4:7])
    tau, p, e = work[0:3], work[3:7], work[7:11]
    if torque_needs_attitude(tk, tP):
        quat_exp(u, e)  # the stage's attitude p_n ∘ exp_S3(u) (eq. 171)
        qmul(y[0:4], e, p)
    rigid_body_rates(t, p, w, I, Iinv, tk, tP, tT, tau, dy[7:10])
    return OK


@ijit
def lie_update(y, work):
    """Seed 004 algorithm 172: ``p_out = p_0 ∘ exp_S3(u)``; the unit norm holds by construction."""
    e = work[0:4]
    quat_exp(y[4:7], e)
    qmul(y[0:4], e, y[0:4])
    y[4] = y[5] = y[6] = 0.0


def _enc_local(q0, w0, seq):
    """A local-chart state ``q_ref(4), v(3) = 0, w(3)``."""
    return np.concatenate([q0, np.zeros_like(w0), w0], axis=-1)


def _dec_lie(y, seq):
    return y[:, 0:4].copy(), y[:, 7:10].copy(), {}


LIE = declare(Scheme("lie", size=10, first=4, deriv=deriv_lie, after_step=lie_update, encode=_enc_local,
                     decode=_dec_lie, work=11))
#: The commutator-free method of order 4 (:func:`cf4_step`) on the LIE state: its stages all have u = 0.
CF4 = declare(Scheme("lie-cf4", size=10, first=4, deriv=deriv_lie, step="cf4", encode=_enc_local,
                     decode=_dec_lie, work=31))


# ------------------------------------------------------------------------------------------------
# DCM: RK4 on R' = R [w x] with Björck-Bowie (seed 000)
# ------------------------------------------------------------------------------------------------
@ijit
def deriv_dcm(t, y, dy, I, Iinv, tk, tP, tT, work):
    """``R' = R [w x]`` (seed 000 eq. 1.7 for the body -> world matrix; seed 004 eq. 131)."""
    R = y[0:9]
    w = y[9:12]
    for r in range(3):
        x0, x1, x2 = R[3 * r], R[3 * r + 1], R[3 * r + 2]
        dy[3 * r] = x1 * w[2] - x2 * w[1]
        dy[3 * r + 1] = x2 * w[0] - x0 * w[2]
        dy[3 * r + 2] = x0 * w[1] - x1 * w[0]
    tau, q = work[0:3], work[3:7]
    if torque_needs_attitude(tk, tP):
        dcm_to_quat(R, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[9:12])
    return OK


@jit
def orthonormalise_dcm(y, bjorck_tol, work):
    bjorck(y[0:9], bjorck_tol, work)


def _enc_dcm(q0, w0, seq):
    R = rot.quat_to_dcm(q0)
    return np.concatenate([R.reshape(R.shape[:-2] + (9,)), w0], axis=-1)


@jit
def dcm_rows_to_quat(y, q, ortho):
    """Decode the DCM rows of ``y`` (n, 12): their quaternions (``w >= 0``, as xcheck.rotations.dcm_to_quat) and
    ``max |R^T R - I|``, in one compiled pass (numpy's batched 3x3 products cost more than the integration)."""
    for r in range(y.shape[0]):
        R = y[r, 0:9]
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
    return continuous_quaternions(q), y[:, 9:12].copy(), {"orthogonality": ortho}


DCM = declare(Scheme("dcm", size=12, deriv=deriv_dcm, after_step=orthonormalise_dcm, encode=_enc_dcm,
                     decode=_dec_dcm, work=18))


# ------------------------------------------------------------------------------------------------
# GIBBS and ROTVEC: global charts re-centred before their singularities (seed 000)
# ------------------------------------------------------------------------------------------------
@ijit
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
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[7:10])
    return OK


@ijit
def deriv_rotvec(t, y, dy, I, Iinv, tk, tP, tT, work):
    """Rotation-vector kinematics with the non-commutativity term (seed 000 §1.5.2); attitude ``q_ref ⊗ exp(phi)``."""
    phi = y[4:7]
    w = y[7:10]
    dexpinv_minus(phi, w, dy[4:7])
    tau, q, e = work[0:3], work[3:7], work[7:11]
    if torque_needs_attitude(tk, tP):
        quat_exp(phi, e)
        qmul(y[0:4], e, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[7:10])
    return OK


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


def _dec_local(to_quat):
    """Decoder of a local-chart state ``q_ref(4), v(3), w(3)``: attitude ``q_ref ⊗ to_quat(v)``."""
    def decode(y, seq):
        q = rot.quat_mul(y[:, 0:4], to_quat(y[:, 4:7]))
        return continuous_quaternions(q), y[:, 7:10].copy(), {}
    return decode


GIBBS = declare(Scheme("gibbs", size=10, first=4, deriv=deriv_gibbs, before_step=recentre_gibbs,
                       encode=_enc_local, decode=_dec_local(rot.gibbs_to_quat), work=11))
ROTVEC = declare(Scheme("rotvec", size=10, first=4, deriv=deriv_rotvec, before_step=recentre_rotvec,
                        encode=_enc_local, decode=_dec_local(rot.rotvec_to_quat), work=11))

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


@ijit
def deriv_mrp(t, y, dy, I, Iinv, tk, tP, tT, work):
    """``s' = 1/4 ((1 - |s|^2) I + 2 [s x] + 2 s s^T) w`` (Schaub & Junkins; xcheck.rotations.mrp_rate), the
    kinematics Basilisk's hub integrates."""
    s = y[0:3]
    w = y[3:6]
    s2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    sw = s[0] * w[0] + s[1] * w[1] + s[2] * w[2]
    dy[0] = 0.25 * ((1.0 - s2) * w[0] + 2.0 * (s[1] * w[2] - s[2] * w[1]) + 2.0 * s[0] * sw)
    dy[1] = 0.25 * ((1.0 - s2) * w[1] + 2.0 * (s[2] * w[0] - s[0] * w[2]) + 2.0 * s[1] * sw)
    dy[2] = 0.25 * ((1.0 - s2) * w[2] + 2.0 * (s[0] * w[1] - s[1] * w[0]) + 2.0 * s[2] * sw)
    tau, q = work[0:3], work[3:7]
    if torque_needs_attitude(tk, tP):
        mrp_quat(s, q)
    rigid_body_rates(t, q, w, I, Iinv, tk, tP, tT, tau, dy[3:6])
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
    return continuous_quaternions(rot.mrp_to_quat(y[:, 0:3])), y[:, 3:6].copy(), {}


MRP = declare(Scheme("mrp", size=6, deriv=deriv_mrp, after_step=shadow_mrp, encode=_enc_mrp, decode=_dec_mrp,
                     work=7))

# ------------------------------------------------------------------------------------------------
# LANES: a batch of bodies in lockstep (Formulation II and the Lie-group method)
# ------------------------------------------------------------------------------------------------
# A batch runs :func:`run` for each body, one after the other in each thread: the scalar code of one body keeps a
# core busy with one body's dependencies. The lanes run a block of bodies in lockstep instead, the state as
# (component, body) arrays, every stage a loop over the bodies of the block doing the scalar forms above
# (``f2_kinematics``, ``dexpinv_apply``, ``euler_rates``, ...), which the compiler turns into vector instructions:
# measured on Formulation II, 4.9e7 body-steps a second on one core against 1.0e7, the same numbers bit for bit
# (the tests compare every component with run's). What needs a branch per body (a rotation beyond the series'
# range, a torque through its field model) is done for the bodies that need it in a loop of its own.
#: Bodies in a block.
LANES = 128
#: The classical RK4's weights b = (1/6, 1/3, 1/3, 1/6) as floats (the lanes' weighted sum; the generated step's
#: literals are the same floats).
RK4_B0, RK4_B1 = 1.0 / 6.0, 1.0 / 3.0


@ijit
def lanes_torque(t, S, attitude, tk, tP, tT, tau, q, out, nb, w_row):
    """The torque of every body of the block at its stage ``S``: written once for FREE and CONSTANT; a MAGNETIC
    model body by body, with the attitude ``attitude(S, k, q)`` writes (the scheme's) and the rate at ``w_row``."""
    if tk == 0:  # FREE: fields.kernel.torque_eval writes zeros
        for j in range(3):
            for k in range(nb):
                tau[j, k] = 0.0
    elif tk == 1:  # CONSTANT
        for j in range(3):
            for k in range(nb):
                tau[j, k] = tP[j]
    else:
        for k in range(nb):
            if torque_needs_attitude(tk, tP):
                attitude(S, k, q)
            for j in range(3):
                out[j] = S[w_row + j, k]
            torque_eval(tk, tP, tT, t, q, out, out[3:6])
            for j in range(3):
                tau[j, k] = out[3 + j]


@ijit
def lanes_rates(S, D, IL, JL, shared, k0, tau, nb, w_row):
    """``D[w_row:w_row+3] = w'`` of every body (Euler's equation, :func:`euler_rates`), its inertia shared by the
    batch (``shared``: read once) or its own (``IL``, ``JL``: the 9 entries of I and I^-1 by body)."""
    if shared:
        i00, i01, i02, i10, i11, i12, i20, i21, i22 = (IL[0, 0], IL[1, 0], IL[2, 0], IL[3, 0], IL[4, 0], IL[5, 0],
                                                       IL[6, 0], IL[7, 0], IL[8, 0])
        j00, j01, j02, j10, j11, j12, j20, j21, j22 = (JL[0, 0], JL[1, 0], JL[2, 0], JL[3, 0], JL[4, 0], JL[5, 0],
                                                       JL[6, 0], JL[7, 0], JL[8, 0])
        for k in range(nb):
            D[w_row, k], D[w_row + 1, k], D[w_row + 2, k] = euler_rates(
                i00, i01, i02, i10, i11, i12, i20, i21, i22, j00, j01, j02, j10, j11, j12, j20, j21, j22,
                tau[0, k], tau[1, k], tau[2, k], S[w_row, k], S[w_row + 1, k], S[w_row + 2, k])
    else:
        for k in range(nb):
            g = k0 + k
            D[w_row, k], D[w_row + 1, k], D[w_row + 2, k] = euler_rates(
                IL[0, g], IL[1, g], IL[2, g], IL[3, g], IL[4, g], IL[5, g], IL[6, g], IL[7, g], IL[8, g],
                JL[0, g], JL[1, g], JL[2, g], JL[3, g], JL[4, g], JL[5, g], JL[6, g], JL[7, g], JL[8, g],
                tau[0, k], tau[1, k], tau[2, k], S[w_row, k], S[w_row + 1, k], S[w_row + 2, k])


@ijit
def lanes_attitude_f2(S, k, q):
    for j in range(4):
        q[j] = S[j, k]


@jit
def lanes_stage_f2(t, S, D, IL, JL, shared, k0, tk, tP, tT, tau, C, q, out, nb):
    """:func:`deriv_formulation2` for every body of the block."""
    lanes_torque(t, S, lanes_attitude_f2, tk, tP, tT, tau, q, out, nb, 4)
    for k in range(nb):
        D[0, k], D[1, k], D[2, k], D[3, k] = f2_kinematics(S[0, k], S[1, k], S[2, k], S[3, k], S[4, k], S[5, k],
                                                           S[6, k])
    lanes_rates(S, D, IL, JL, shared, k0, tau, nb, 4)


@jit
def lanes_after_f2(Y, C, nb):
    """:func:`normalise_formulation2` for every body."""
    for k in range(nb):
        n = np.sqrt(Y[0, k] * Y[0, k] + Y[1, k] * Y[1, k] + Y[2, k] * Y[2, k] + Y[3, k] * Y[3, k])
        for j in range(4):
            Y[j, k] /= n


@ijit
def lanes_exp(Y, row, C, nb):
    """``C[0:4, k] = exp_S3(Y[row:row+3, k])`` for every body (:func:`quat_exp`: the series where it holds, for
    every body at once; the others again with their sine and cosine)."""
    for k in range(nb):
        a2 = Y[row, k] * Y[row, k] + Y[row + 1, k] * Y[row + 1, k] + Y[row + 2, k] * Y[row + 2, k]
        C[4, k] = a2
        C[0, k], C[1, k] = exp_coefs_series(0.25 * a2)
    for k in range(nb):
        if 0.25 * C[4, k] >= SERIES_ANGLE * SERIES_ANGLE:
            C[0, k], C[1, k] = exp_coefs_trig(C[4, k])
    for k in range(nb):
        c, s = C[0, k], C[1, k]
        C[0, k] = c
        C[1, k] = s * Y[row, k]
        C[2, k] = s * Y[row + 1, k]
        C[3, k] = s * Y[row + 2, k]


@ijit
def lanes_attitude_lie(S, k, q):
    """The stage's attitude ``p_n ∘ exp_S3(u)`` (eq. 171) of body ``k``."""
    a2 = S[4, k] * S[4, k] + S[5, k] * S[5, k] + S[6, k] * S[6, k]
    h2 = 0.25 * a2
    c, s = exp_coefs_series(h2) if h2 < SERIES_ANGLE * SERIES_ANGLE else exp_coefs_trig(a2)
    q[0], q[1], q[2], q[3] = qmul_s(S[0, k], S[1, k], S[2, k], S[3, k], c, s * S[4, k], s * S[5, k], s * S[6, k])


@jit
def lanes_stage_lie(t, S, D, IL, JL, shared, k0, tk, tP, tT, tau, C, q, out, nb):
    """:func:`deriv_lie` (``yhat`` = ``y``: lie-rkmk4) for every body of the block: the dexp^-1 coefficient by
    its series for every body, again with the cotangent for those beyond its range."""
    lanes_torque(t, S, lanes_attitude_lie, tk, tP, tT, tau, q, out, nb, 7)
    for k in range(nb):
        a2 = S[4, k] * S[4, k] + S[5, k] * S[5, k] + S[6, k] * S[6, k]
        C[4, k] = a2
        C[0, k] = dexpinv_coef_series(a2)
    for k in range(nb):
        if C[4, k] >= SERIES_ANGLE * SERIES_ANGLE:
            C[0, k] = dexpinv_coef_trig(C[4, k])
    for k in range(nb):
        D[4, k], D[5, k], D[6, k] = dexpinv_apply(S[4, k], S[5, k], S[6, k], S[7, k], S[8, k], S[9, k], C[0, k])
    lanes_rates(S, D, IL, JL, shared, k0, tau, nb, 7)


@jit
def lanes_after_lie(Y, C, nb):
    """:func:`lie_update` for every body: ``p <- p ∘ exp_S3(u)``, ``u <- 0``."""
    lanes_exp(Y, 4, C, nb)
    for k in range(nb):
        Y[0, k], Y[1, k], Y[2, k], Y[3, k] = qmul_s(Y[0, k], Y[1, k], Y[2, k], Y[3, k], C[0, k], C[1, k], C[2, k],
                                                    C[3, k])
        Y[4, k] = 0.0
        Y[5, k] = 0.0
        Y[6, k] = 0.0


#: The schemes with lanes: their stage and after-step functions (by name, for the generated entry points).
LANES_OF = {F2: ("lanes_stage_f2", "lanes_after_f2"), LIE: ("lanes_stage_lie", "lanes_after_lie")}


@ijit
def run_lanes(scheme, stage, after, a, Y0, IL, JL, shared, out, steps_done, status, k0, nb, Y, S, K, Yp, tau, C,
              q, tout):
    """:func:`run` for the bodies ``k0 .. k0 + nb`` of ``Y0`` in lockstep (see the section's comment), the classical
    classical RK4 (:data:`RK4_STEP`) stage by stage, ``stage`` and ``after`` the scheme's lanes; per body the same arithmetic,
    the same stop at a non-finite state, the same rows in ``out``."""
    m = STATE_SIZE[scheme]
    first = FIRST[scheme]
    n, dt, last_h, save_every, c = a.n, a.dt, a.last_h, a.save_every, a.c
    tk, tP, tT = a.tk, a.tP, a.tT
    for k in range(nb):
        status[k0 + k] = OK
        for l in range(m):
            Y[l, k] = Y0[k0 + k, l]
            out[k0 + k, 0, l] = Y0[k0 + k, l]
    row = 1
    until_save = save_every
    for step in range(n):
        h = dt if step < n - 1 else last_h
        t = step * dt
        for l in range(m):
            for k in range(nb):
                Yp[l, k] = Y[l, k]
                S[l, k] = Y[l, k]
        for i in range(4):
            if i > 0:
                Kp = K[i - 1]
                for l in range(first, m):
                    for k in range(nb):
                        S[l, k] = Y[l, k] + h * (Kp[l, k] if i == 3 else 0.5 * Kp[l, k])
            stage(t + c[i] * h, S, K[i], IL, JL, shared, k0, tk, tP, tT, tau, C, q, tout, nb)
        K0, K1, K2, K3 = K[0], K[1], K[2], K[3]
        for l in range(first, m):
            for k in range(nb):
                Y[l, k] += h * (((RK4_B0 * K0[l, k] + RK4_B1 * K1[l, k]) + RK4_B1 * K2[l, k]) + RK4_B0 * K3[l, k])
        after(Y, C, nb)
        for k in range(nb):
            if status[k0 + k] != OK:
                continue
            for l in range(m):
                if not np.isfinite(Y[l, k]):
                    status[k0 + k] = NONFINITE
            if status[k0 + k] != OK:  # the last good state fills the remaining rows
                steps_done[k0 + k] = step
                for r in range(row, out.shape[1]):
                    for l in range(m):
                        out[k0 + k, r, l] = Yp[l, k]
        until_save -= 1
        if until_save == 0 or step == n - 1:
            for k in range(nb):
                if status[k0 + k] == OK:
                    for l in range(m):
                        out[k0 + k, row, l] = Y[l, k]
            row += 1
            until_save = save_every
    for k in range(nb):
        if status[k0 + k] == OK:
            steps_done[k0 + k] = n


#: Derived from the registry (compile-time constants inside the kernels).
STATE_SIZE = tuple(s.size for s in SCHEMES)
FIRST = tuple(s.first for s in SCHEMES)
WORK_SIZE = tuple(max(s.work, 1) for s in SCHEMES)


# ------------------------------------------------------------------------------------------------
# dispatch by scheme: plain Python for the interpreted variant; compiled, an overload keeps only the
# scheme's own code (the scheme is a literal there)
# ------------------------------------------------------------------------------------------------
#: What a derivative and a hook may ask for, by parameter name: each takes the subset it needs, in any order,
#: and :func:`_adapter` passes just that (fewer arguments per call is measurably faster on one trajectory).
DERIV_ARGS = ("t", "y", "yhat", "dy", "I", "Iinv", "tk", "tP", "tT", "axes", "sing_tol", "work")
HOOK_ARGS = ("y", "bjorck_tol", "work")


def _adapter(f, offered):
    """``lambda scheme, *offered: f(<the parameters f names>)``, or a lambda that does nothing when ``f`` is
    None (a scheme without that hook)."""
    if f is None:
        return eval(f"lambda scheme, {', '.join(offered)}: None")
    names = list(inspect.signature(getattr(f, "py_func", f)).parameters)
    unknown = [n for n in names if n not in offered]
    if unknown:
        raise TypeError(f"{f.__name__}: parameters {unknown} are not among {offered}")
    return eval(f"lambda scheme, {', '.join(offered)}: f({', '.join(names)})", {"f": f})


def deriv(scheme, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work):
    """The stage derivative of ``scheme``; returns OK or SINGULAR."""
    return _DERIV[scheme](scheme, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work)


def before_step(scheme, y, bjorck_tol, work):
    _BEFORE[scheme](scheme, y, bjorck_tol, work)


def after_step(scheme, y, bjorck_tol, work):
    _AFTER[scheme](scheme, y, bjorck_tol, work)


_DERIV = [_adapter(sc.deriv, DERIV_ARGS) for sc in SCHEMES]
_BEFORE = [_adapter(sc.before_step, HOOK_ARGS) for sc in SCHEMES]
_AFTER = [_adapter(sc.after_step, HOOK_ARGS) for sc in SCHEMES]

if not PYTHON_MODE:

    def _literal(scheme):
        return scheme.literal_value if isinstance(scheme, numba.types.IntegerLiteral) else None

    # (numba retries with the literal scheme when an overload answers None)
    @overload(deriv, inline="always")
    def _deriv(scheme, t, y, yhat, dy, I, Iinv, tk, tP, tT, axes, sing_tol, work):
        return None if _literal(scheme) is None else _DERIV[_literal(scheme)]

    @overload(before_step, inline="always")
    def _before_step(scheme, y, bjorck_tol, work):
        return None if _literal(scheme) is None else _BEFORE[_literal(scheme)]

    @overload(after_step, inline="always")
    def _after_step(scheme, y, bjorck_tol, work):
        return None if _literal(scheme) is None else _AFTER[_literal(scheme)]


# ------------------------------------------------------------------------------------------------
# the steps: the stage arithmetic for every tableau, and the commutator-free step
# ------------------------------------------------------------------------------------------------
def _term(coef, k: int) -> str:
    """``coef * K[k, l]`` as source, the coefficient a literal of its float (1 left out)."""
    x = float(coef)
    return f"K[{k}, l]" if x == 1.0 else f"{x!r} * K[{k}, l]"


def _sum(row) -> str | None:
    """The stage sum ``sum_j row_j K_j`` as source, left to right, zeros left out; None when all are zero."""
    terms = [_term(a, j) for j, a in enumerate(row) if a != 0]
    return " + ".join(terms) if terms else None


def rk_step_source(name: str, A, b, c, Ahat=None) -> str:
    """The source of one step of the explicit Runge-Kutta method ``(A, b, c)`` (exact fractions: each coefficient
    compiled in as a literal of its float, zeros left out), for any scheme::

        K_i = f(t + c_i h, y + h sum_j A_ij K_j),    y <- y + h sum_i b_i K_i

    on the components of ``y`` from the scheme's ``first`` on (the others, a reference quaternion, are constant
    in the step). ``Ahat`` (the printed Lie algorithm 172's): a second set of stage values passed to the derivative
    as ``yhat``. ``y`` is left unchanged if a stage fails. The arithmetic is the stage sums' own, left to right:
    for RK4 the numbers of the hand-written loop it replaced, bit for bit."""
    s = len(b)
    lines = [f"def {name}(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, Ahat, use_hat, tk, tP, tT, axes, sing_tol,",
             "        work):",
             "    m = STATE_SIZE[scheme]",
             "    first = FIRST[scheme]",
             "    for l in range(m):  # the first components are constant in the step (a reference quaternion)",
             "        Y[l] = y[l]"]
    if Ahat is not None:
        lines += ["        Yhat[l] = y[l]"]
    hat = "Yhat" if Ahat is not None else "Y"
    for i in range(s):
        body = []
        stage = _sum(A[i][:i])
        if i > 0:
            body.append(f"        Y[l] = y[l] + h * ({stage})" if stage else "        Y[l] = y[l]")
        if Ahat is not None and i > 0:
            stage_hat = _sum(Ahat[i][:i])
            body.append(f"        Yhat[l] = y[l] + h * ({stage_hat})" if stage_hat else "        Yhat[l] = y[l]")
        if body:
            lines += ["    for l in range(first, m):", *body]
        ci = float(c[i])
        when = "t" if ci == 0.0 else ("t + h" if ci == 1.0 else f"t + {ci!r} * h")
        lines += [f"    status = deriv(scheme, {when}, Y, {hat}, K[{i}], I, Iinv, tk, tP, tT, axes, sing_tol, work)",
                  "    if status != OK:",
                  "        return status"]
    lines += ["    for l in range(first, m):",
              f"        y[l] += h * ({_sum(b)})",
              "    return OK"]
    return "\n".join(lines) + "\n"


#: The generated steps, by name (:func:`rk_step_for`).
RK_STEPS: dict = {}


def rk_step_for(tableau, dexp_A=None) -> str:
    """The name of the compiled step of ``tableau`` (a :class:`~xcheck.integrators.tableau.ButcherTableau`; with the
    printed algorithm 172's ``dexp_A``), generated from its exact fractions the first time it is asked for and
    compiled from text under this file's name (numba caches it like a function written out here)."""
    ident = "rk_step_" + "".join(ch if ch.isalnum() else "_" for ch in tableau.name) + ("_hat" if dexp_A else "")
    if ident not in RK_STEPS:
        if any(tableau.A[i][j] != 0 for i in range(tableau.stages) for j in range(i, tableau.stages)):
            raise ValueError(f"{tableau.name}: an implicit tableau (A not strictly lower triangular); the kernels "
                             "run explicit Runge-Kutta methods")
        namespace = globals()
        exec(compile(rk_step_source(ident, tableau.A, tableau.b, tableau.c, dexp_A), __file__, "exec"), namespace)
        RK_STEPS[ident] = namespace[ident] = ijit(namespace[ident])
    return ident


#: The classical RK4's generated step (the lanes run its arithmetic, body by body in lockstep).
RK4_STEP = rk_step_for(RK4)


#: CF4's coefficients (Celledoni, Marthinsen and Owren 2003, eq. 16), for body rates acting on the right:
#: stage i's attitude is ``base_i ∘ exp(h sum_j CF4_ALPHA[i, j] k_j)`` with ``base`` p_n, except stage 4, whose
#: base is stage 2's attitude; the step ends with ``p_n ∘ exp(h sum CF4_BETA[0] k) ∘ exp(h sum CF4_BETA[1] k)``.
#: The rates w follow the classical RK4 (the tableau's A and b).
CF4_ALPHA = np.array([[0.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0], [-0.5, 0.0, 1.0, 0.0]])
CF4_BETA = np.array([[3.0, 2.0, 2.0, -1.0], [-1.0, 2.0, 2.0, 3.0]]) / 12.0


@ijit
def cf4_step(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, Ahat, use_hat, tk, tP, tT, axes, sing_tol, work):
    """The commutator-free Lie group method of order 4 (Celledoni, Marthinsen and Owren 2003, their CF4) for
    ``p' = p ∘ w`` (body rates act on the right) and Euler's equation, on the LIE state. With ``k_i`` the
    body rate and ``F_i`` the rate derivative of stage i::

        p2 = p ∘ exp(h/2 k1)             w2 = w + h/2 F1
        p3 = p ∘ exp(h/2 k2)             w3 = w + h/2 F2
        p4 = p2 ∘ exp(h k3 - h/2 k1)     w4 = w + h F3
        p <- p ∘ exp(h/12 (3 k1 + 2 k2 + 2 k3 - k4)) ∘ exp(h/12 (-k1 + 2 k2 + 2 k3 + 3 k4))
        w <- w + h/6 (F1 + 2 F2 + 2 F3 + F4)

    (:data:`CF4_ALPHA`, :data:`CF4_BETA`). No dexp^-1 is needed, each stage's attitude is a unit quaternion
    by construction, and w follows the classical RK4. The stage derivative is LIE's at u = 0:
    ``K[i, 4:7] = k_i``, ``K[i, 7:10] = F_i``."""
    v, e, p2 = work[20:23], work[23:27], work[27:31]
    Y[4] = Y[5] = Y[6] = 0.0
    for i in range(4):
        for l in range(3):
            acc_v = 0.0
            acc_w = 0.0
            for j in range(i):
                acc_v += CF4_ALPHA[i, j] * K[j, 4 + l]
                acc_w += A[i, j] * K[j, 7 + l]
            v[l] = h * acc_v
            Y[7 + l] = y[7 + l] + h * acc_w
        quat_exp(v, e)
        if i == 3:
            qmul(p2, e, Y[0:4])
        else:
            qmul(y[0:4], e, Y[0:4])
        if i == 1:
            for l in range(4):
                p2[l] = Y[l]
        status = deriv(scheme, t + c[i] * h, Y, Y, K[i], I, Iinv, tk, tP, tT, axes, sing_tol, work)
        if status != OK:
            return status
    for r in range(2):
        for l in range(3):
            acc = 0.0
            for j in range(4):
                acc += CF4_BETA[r, j] * K[j, 4 + l]
            v[l] = h * acc
        quat_exp(v, e)
        qmul(y[0:4], e, y[0:4])
    for l in range(3):
        acc = 0.0
        for j in range(4):
            acc += b[j] * K[j, 7 + l]
        y[7 + l] += h * acc
    return OK


# ------------------------------------------------------------------------------------------------
# the loops and the two entry points
# ------------------------------------------------------------------------------------------------
@ijit
def run(scheme, step_fn, a, y0, I, Iinv, out, K, Y, Yhat, work, y, y_prev):
    """Integrate ``a.n`` steps with ``step_fn`` (a generated RK step, :func:`rk_step_for`, or :func:`cf4_step`) (the last of length
    ``a.last_h``) from ``y0``; store ``y`` every ``a.save_every`` steps and at the end into ``out`` (row 0 =
    ``y0``). ``K, Y, Yhat, work, y, y_prev`` are scratch (:func:`scratch`). Returns (steps done, status): on a
    singular or non-finite step the loop stops, and ``out``'s remaining rows hold the last good state."""
    m = STATE_SIZE[scheme]
    for l in range(m):
        y[l] = y0[l]
        out[0, l] = y[l]
    row = 1
    until_save = a.save_every
    n, dt, last_h, save_every, bjorck_tol = a.n, a.dt, a.last_h, a.save_every, a.bjorck_tol
    A, b, c, Ahat, use_hat = a.A, a.b, a.c, a.Ahat, a.use_hat  # the record unpacked once per run
    tk, tP, tT, axes, sing_tol = a.tk, a.tP, a.tT, a.axes, a.sing_tol
    for step in range(n):
        h = dt if step < n - 1 else last_h
        t = step * dt
        before_step(scheme, y, bjorck_tol, work)
        for l in range(m):
            y_prev[l] = y[l]
        status = step_fn(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, Ahat, use_hat, tk, tP, tT, axes, sing_tol,
                         work)
        if status == OK:
            after_step(scheme, y, bjorck_tol, work)
            for l in range(m):
                if not np.isfinite(y[l]):
                    status = NONFINITE
        if status != OK:  # the last good state fills the remaining rows
            for r in range(row, out.shape[0]):
                for l in range(m):
                    out[r, l] = y_prev[l]
            return step, status
        until_save -= 1
        if until_save == 0 or step == n - 1:
            for l in range(m):
                out[row, l] = y[l]
            row += 1
            until_save = save_every
    return n, OK


def _entry_points(scheme: int, step: str):
    """The two compiled entry points of ``scheme`` stepped by ``step`` (a generated RK step, :func:`rk_step_for`, or
    :func:`cf4_step`), made from the registry: ``run_<name>__<step>(a, y0, I, Iinv, out, K, Y, Yhat, work, y,
    y_prev)`` (the scratch arrays of :func:`run`, allocated by the caller: the loop itself neither allocates nor
    counts references) and ``many_<name>__<step>(a, Y0, I, Iinv, out, steps_done, status, K, Y, Yhat, work, y,
    y_prev)``, which calls the first for each row in parallel threads, each row with its own scratch. The scheme is a
    literal constant and its step function is named in their source (an overload choosing the step doubled the
    compile time). They are compiled from text under this file's name so that numba caches them like functions
    written out here (a closure would miss the cache on every run, and ``numba.literally`` re-types every call: 67
    ms)."""
    ident = SCHEMES[scheme].name.replace("-", "_") + "__" + step
    namespace = dict(globals())
    exec(compile(f"def run_{ident}(a, y0, I, Iinv, out, K, Y, Yhat, work, y, y_prev):\n"
                 f"    return run({scheme}, {step}, a, y0, I, Iinv, out, K, Y, Yhat, work, y, y_prev)\n",
                 __file__, "exec"), namespace)
    one = namespace[f"run_{ident}"] = jit(namespace[f"run_{ident}"])
    exec(compile(f"def many_{ident}(a, Y0, I, Iinv, out, steps_done, status, K, Y, Yhat, work, y, y_prev):\n"
                 f"    for k in prange(Y0.shape[0]):\n"
                 f"        nd, st = run_{ident}(a, Y0[k], I[k], Iinv[k], out[k], K[k], Y[k], Yhat[k], work[k], y[k],\n"
                 f"                             y_prev[k])\n"
                 f"        steps_done[k] = nd\n"
                 f"        status[k] = st\n",
                 __file__, "exec"), namespace)
    return one, pjit(namespace[f"many_{ident}"])


#: The entry points made so far, by (scheme, step): each on first use (:func:`entry_points`).
_ENTRIES: dict = {}


def entry_points(scheme: int, step: str):
    """``(run_one, run_many)`` compiled for ``scheme`` stepped by ``step``, made the first time they are asked for."""
    if (scheme, step) not in _ENTRIES:
        _ENTRIES[scheme, step] = _entry_points(scheme, step)
    return _ENTRIES[scheme, step]


def step_of(scheme: int, tableau, dexp_A=None) -> str:
    """The step function's name of ``scheme`` on ``tableau``: CF4's own step, or the tableau's generated RK step."""
    return "cf4_step" if SCHEMES[scheme].step == "cf4" else rk_step_for(tableau, dexp_A)


def _lanes_entry(scheme: int):
    """``lanes_<name>(a, Y0, IL, JL, shared, out, steps_done, status, k0, nb, Y, S, K, Yp, tau, C, q, tout)``:
    :func:`run_lanes` of the scheme for one block of bodies, compiled once, without the interpreter's lock: the
    blocks go to threads of this process (:func:`run_many`). Made from text like :func:`_entry_points`, the
    scheme's lanes functions named in it. (A parallel loop over the blocks compiled in took 5.6 s more to compile
    a scheme for the same speed.)"""
    ident = SCHEMES[scheme].name.replace("-", "_")
    stage, after = LANES_OF[scheme]
    namespace = dict(globals())
    exec(compile(f"def lanes_{ident}(a, Y0, IL, JL, shared, out, steps_done, status, k0, nb, Y, S, K, Yp, tau, C, q,\n"
                 f"                tout):\n"
                 f"    run_lanes({scheme}, {stage}, {after}, a, Y0, IL, JL, shared, out, steps_done, status, k0, nb,\n"
                 f"              Y, S, K, Yp, tau, C, q, tout)\n",
                 __file__, "exec"), namespace)
    return jit_nogil(namespace[f"lanes_{ident}"])


RUN_LANES = {k: _lanes_entry(k) for k in LANES_OF} if not PYTHON_MODE else {}


def _lanes_blocks(scheme, a, Y0, IL, JL, shared, out, steps_done, status, blocks):
    """The ``blocks`` (indices) of the batch, one after the other, each with fresh scratch."""
    m = STATE_SIZE[scheme]
    scr = (np.zeros((m, LANES)), np.zeros((m, LANES)), np.zeros((4, m, LANES)), np.zeros((m, LANES)),
           np.zeros((3, LANES)), np.zeros((5, LANES)), np.zeros(4), np.zeros(6))
    for b in blocks:
        k0 = b * LANES
        RUN_LANES[scheme](a, Y0, IL, JL, shared, out, steps_done, status, k0, min(LANES, Y0.shape[0] - k0), *scr)


_THREADS: list = []


def _threads():
    """A pool of threads, one a CPU, kept for the process (the lanes release the interpreter's lock)."""
    if not _THREADS:
        import os
        from concurrent.futures import ThreadPoolExecutor

        _THREADS.append(ThreadPoolExecutor(max_workers=os.cpu_count() or 1, thread_name_prefix="xcheck-lanes"))
    return _THREADS[0]


def scratch(scheme, a, *batch):
    """The scratch arrays of :func:`run` (K, Y, Yhat, work, y, y_prev), with leading dimensions ``batch``."""
    m = STATE_SIZE[scheme]
    return (np.zeros((*batch, max(a.b.shape[0], 4), m)),  # CF4 has 4 stages whatever the tableau
            np.zeros((*batch, m)), np.zeros((*batch, m)), np.zeros((*batch, WORK_SIZE[scheme])),
            np.zeros((*batch, m)), np.zeros((*batch, m)))


def run_one(scheme, step, a, y0, I, Iinv, out):
    """One trajectory of ``scheme`` stepped by ``step`` (:func:`run`, :func:`step_of`): (steps done, status)."""
    return entry_points(scheme, step)[0](a, y0, I, Iinv, out, *scratch(scheme, a))


def run_many(scheme, step, a, Y0, I, Iinv, out, steps_done, status):
    """:func:`run` for each row of ``Y0`` (N, m), in parallel threads; ``I``, ``Iinv`` are (N, 3, 3). A scheme with
    lanes on the classical RK4 of its own stage values (not the printed algorithm 172's) runs them instead: the same
    numbers, blocks of bodies in lockstep."""
    if scheme in RUN_LANES and step == RK4_STEP:
        N = Y0.shape[0]
        IL = np.ascontiguousarray(I.reshape(N, 9).T)
        JL = np.ascontiguousarray(Iinv.reshape(N, 9).T)
        shared = bool(np.all(I == I[0]) and np.all(Iinv == Iinv[0]))
        blocks = list(range((N + LANES - 1) // LANES))
        pool = _threads()
        parts = [blocks[i::pool._max_workers] for i in range(pool._max_workers)]
        jobs = [pool.submit(_lanes_blocks, scheme, a, Y0, IL, JL, shared, out, steps_done, status, part)
                for part in parts if part]
        for job in jobs:
            job.result()
        return
    entry_points(scheme, step)[1](a, Y0, I, Iinv, out, steps_done, status, *scratch(scheme, a, Y0.shape[0]))
