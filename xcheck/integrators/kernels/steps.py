"""The steps: a scheme's derivative and hooks chosen at compile time (:func:`deriv`, :func:`before_step`,
:func:`after_step`), the Runge-Kutta stage loop generated from each tableau's exact fractions (:func:`rk_step_for`),
the commutator-free step (:func:`cf4_step`), the Lie group variational integrator's (:func:`lgvi_step`) and the
splitting methods' (:func:`split2_step`, :func:`split4_step`)."""

from __future__ import annotations

import inspect

import numpy as np

from ..tableau import RK4
from ._variant import PYTHON_MODE, ijit, jit, numba, overload, torque_eval, torque_needs_rate
from .freeflow import free_flow, principal_frame
from .registry import NOT_CONVERGED, OK, OVER_BUDGET, SCHEMES
from .helpers import cross, qmul, quat_exp
from .schemes import CF4_WORK, FIRST, LGVI_STATE, LGVI_WORK, LIE_STATE, SPLIT_STATE, SPLIT_WORK, STATE_SIZE  # noqa: F401 (read by the generated steps' source, and the schemes declared first)


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
    lines = [f"def {name}(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, tk, tP, tT, axes, sing_tol, work):",
             "    m = STATE_SIZE[scheme]",
             "    first = FIRST[scheme]",
             "    for l in range(m):  # the first components are constant in the step (a reference quaternion)",
             "        Y[l] = y[l]"]
    if Ahat is not None:
        lines += ["        Yhat[l] = y[l]"]
    hat = "Yhat" if Ahat is not None else "Y"
    # one loop over the stages with one call of the derivative (inlined once: unrolled, four inlined copies of a
    # scheme's derivative and torque took three times as long to compile), each stage's sum and node chosen by
    # its index, written out with the tableau's literals
    lines += [f"    for i in range({s}):", "        tc = t"]
    for i in range(s):
        ci = float(c[i])
        when = "t" if ci == 0.0 else ("t + h" if ci == 1.0 else f"t + {ci!r} * h")
        if i == 0 and ci == 0.0:  # explicit: the first stage is the step's start
            continue
        lines += [f"        {'if' if i == 1 or (i == 0) else 'elif'} i == {i}:"]
        if i > 0:
            stage = _sum(A[i][:i])
            lines += ["            for l in range(first, m):",
                      f"                Y[l] = y[l] + h * ({stage})" if stage else "                Y[l] = y[l]"]
            if Ahat is not None:
                stage_hat = _sum(Ahat[i][:i])
                lines += [f"                Yhat[l] = y[l] + h * ({stage_hat})" if stage_hat
                          else "                Yhat[l] = y[l]"]
        lines += [f"            tc = {when}"]
    lines += [f"        status = deriv(scheme, tc, Y, {hat}, K[i], I, Iinv, tk, tP, tT, axes, sing_tol, work)",
              "        if status != OK:",
              "            return status"]
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
def cf4_step(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, tk, tP, tT, axes, sing_tol, work):
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
    v, e, p2 = work[CF4_WORK.v], work[CF4_WORK.ev], work[CF4_WORK.p2]
    p_n = LIE_STATE.p_n
    u0, w0 = LIE_STATE.u.start, LIE_STATE.w.start
    for l in range(3):
        Y[u0 + l] = 0.0
    for i in range(4):
        for l in range(3):
            acc_v = 0.0
            acc_w = 0.0
            for j in range(i):
                acc_v += CF4_ALPHA[i, j] * K[j, u0 + l]
                acc_w += A[i, j] * K[j, w0 + l]
            v[l] = h * acc_v
            Y[w0 + l] = y[w0 + l] + h * acc_w
        quat_exp(v, e)
        if i == 3:
            qmul(p2, e, Y[p_n])
        else:
            qmul(y[p_n], e, Y[p_n])
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
                acc += CF4_BETA[r, j] * K[j, u0 + l]
            v[l] = h * acc
        quat_exp(v, e)
        qmul(y[p_n], e, y[p_n])
    for l in range(3):
        acc = 0.0
        for j in range(4):
            acc += b[j] * K[j, w0 + l]
        y[w0 + l] += h * acc
    return OK


# ------------------------------------------------------------------------------------------------
# the Lie group variational integrator (Lee, Leok & McClamroch)
# ------------------------------------------------------------------------------------------------
#: The implicit equation's Newton iterations at most, and the fixed-point iterations on the end torque at most (a
#: torque that depends on the rate: a gyrostat's wheels; the LGVI's and the splittings' last half kick); both stop
#: where the update is round-off.
LGVI_NEWTON, END_TORQUE_ITERATIONS = 30, 50
#: The LGVI's Newton update that stops shrinking within this of the Cayley vector has reached round-off.
LGVI_STALL = 1e-10


@ijit
def end_torque(t_end, q, base, h, Iinv, tk, tP, tT, M1, M2, P, wn):
    """The torque ``M1`` at a step's end where it depends on the end's rate, ``J^-1 (base + h/2 M1)``: iterated to a
    fixed point from the guess in ``M1`` (``M2``, ``P``, ``wn`` scratch). The LGVI's ``Pi_k+1`` and the splittings'
    last half kick are both ``base + h/2 M1``."""
    for _ in range(END_TORQUE_ITERATIONS):
        for i in range(3):
            P[i] = base[i] + 0.5 * h * M1[i]
        for i in range(3):
            wn[i] = Iinv[i, 0] * P[0] + Iinv[i, 1] * P[1] + Iinv[i, 2] * P[2]
        torque_eval(tk, tP, tT, t_end, q, wn, M2)
        change = abs(M2[0] - M1[0]) + abs(M2[1] - M1[1]) + abs(M2[2] - M1[2])
        for i in range(3):
            M1[i] = M2[i]
        if change <= 4e-16 * (abs(M1[0]) + abs(M1[1]) + abs(M1[2])):
            break


@jit
def solve3(A, r, out):
    """``out = A^-1 r`` for a 3x3 ``A`` (row-major, 9) by Cramer's rule; False where ``A`` is singular."""
    c00 = A[4] * A[8] - A[5] * A[7]
    c01 = A[5] * A[6] - A[3] * A[8]
    c02 = A[3] * A[7] - A[4] * A[6]
    det = A[0] * c00 + A[1] * c01 + A[2] * c02
    if det == 0.0 or not np.isfinite(det):
        return False
    c10 = A[2] * A[7] - A[1] * A[8]
    c11 = A[0] * A[8] - A[2] * A[6]
    c12 = A[1] * A[6] - A[0] * A[7]
    c20 = A[1] * A[5] - A[2] * A[4]
    c21 = A[2] * A[3] - A[0] * A[5]
    c22 = A[0] * A[4] - A[1] * A[3]
    out[0] = (c00 * r[0] + c10 * r[1] + c20 * r[2]) / det
    out[1] = (c01 * r[0] + c11 * r[1] + c21 * r[2]) / det
    out[2] = (c02 * r[0] + c12 * r[1] + c22 * r[2]) / det
    return True


@jit
def rotate_back(q, v, out):
    """``R(q)^T v`` for a unit quaternion ``q``: ``v`` in the frame that ``q`` turns into. The arithmetic of
    :func:`xcheck.fields.kernel.world_to_body` without its normalisation (the step's rotation is unit by construction;
    dividing by its norm again moved the variational integrator's numbers by 1e-9 relative on a tumble)."""
    x, y, z = -q[1], -q[2], -q[3]
    t0 = 2.0 * (y * v[2] - z * v[1])
    t1 = 2.0 * (z * v[0] - x * v[2])
    t2 = 2.0 * (x * v[1] - y * v[0])
    out[0] = v[0] + q[0] * t0 + (y * t2 - z * t1)
    out[1] = v[1] + q[0] * t1 + (z * t0 - x * t2)
    out[2] = v[2] + q[0] * t2 + (x * t1 - y * t0)


#: The most substeps a step of the LGVI is split into where its equation has no solution at the full step.
LGVI_MOST_SUBSTEPS = 1024


@ijit
def lgvi_step(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, tk, tP, tT, axes, sing_tol, work):
    """One step of the LGVI (:func:`lgvi_once`), or, where its implicit equation has no solution at the step ``h``,
    the step as 2, 4, ... substeps (at most :data:`LGVI_MOST_SUBSTEPS`) of it, from the same start (issue 63). The
    discrete equation ``h Pi = (F J_d - J_d F^T)^v`` is solvable only for ``h`` small enough: about a principal
    axis ``sin(turn) = h |w|``, so no step where ``h |w| > 1`` (the reach measured on 300 directions of each of
    three bodies, a thin plate and a rod of moments 0.01, 1, 1.01 among them: ``h |w|`` = 1.000 at the least; a
    damped Newton and a continuation in ``h`` stop there too). Substeps keep what the method keeps (a composition of
    symplectic, momentum-keeping maps is both). ``work[W.split]``: the steps split so far and the most substeps one
    took, for the run's note; NOT_CONVERGED where even the most substeps fail."""
    status = lgvi_once(t, y, h, I, Iinv, tk, tP, tT, work)
    if status != NOT_CONVERGED:
        return status
    return lgvi_substeps(t, y, h, I, Iinv, tk, tP, tT, work)


@jit
def lgvi_substeps(t, y, h, I, Iinv, tk, tP, tT, work):
    """:func:`lgvi_step`'s substeps, compiled apart (not inlined: the common step keeps one copy of the LGVI's
    arithmetic: a day of RAX-1 at 0.1 s takes 0.92 to 0.94 of formulation-2's time, as before the substeps, and
    0.98 with them inlined)."""
    W = LGVI_WORK
    start = work[W.start]
    for i in range(7):
        start[i] = y[i]
    n = 2
    while n <= LGVI_MOST_SUBSTEPS:
        hs = h / n
        status = OK
        for k in range(n):
            status = lgvi_once(t + k * hs, y, hs, I, Iinv, tk, tP, tT, work)
            if status != OK:
                break
        if status == OK:
            split = work[W.split]
            split[0] += 1.0
            split[1] = max(split[1], float(n))
            return OK
        for i in range(7):
            y[i] = start[i]
        n *= 2
    return NOT_CONVERGED


@ijit
def lgvi_once(t, y, h, I, Iinv, tk, tP, tT, work):
    """The Lie group variational integrator of Lee, Leok and McClamroch (2005, a rigid body under a potential; its
    forced form, the discrete Lagrange-d'Alembert principle, as in their 2007 paper's eq. 50-53), with ``J`` the
    inertia tensor, ``Pi = J w`` the body momentum, ``M`` the torque (body components) and ``F`` the step's
    body-frame rotation::

        h Pi_k + h^2/2 M_k = (F J_d - J_d F^T)^v,    J_d = tr(J)/2 E - J
        R_k+1 = R_k F
        Pi_k+1 = F^T Pi_k + h/2 F^T M_k + h/2 M_k+1

    The first is solved for ``F`` by its Cayley vector ``f`` (``F = (E + [f]x)(E - [f]x)^-1``, the quaternion
    ``[1, f] / sqrt(1 + f.f)``): with ``g`` its left side, ``g + g x f + (g.f) f - 2 J f = 0`` (tested against the
    matrix equation), by Newton from ``f = h w / 2``. ``M_k+1`` is the torque at the end, iterated to a fixed point
    where it depends on the end's rate (a gyrostat's wheels). Second order; torque free it keeps the angular
    momentum in the world to round-off and its energy error bounded (it is symplectic). Returns OK, or
    NOT_CONVERGED, ``y`` untouched, where Newton did not converge: where the equation has no solution at ``h``
    (:func:`lgvi_step`)."""
    S, W = LGVI_STATE, LGVI_WORK
    q, w = y[S.p], y[S.w]
    M0, M1, M2, Pi, g, f = work[W.M0], work[W.M1], work[W.M2], work[W.Pi], work[W.g], work[W.f]
    G, jac, df, qf, qn = work[W.G], work[W.jac], work[W.df], work[W.qf], work[W.qn]
    base, wn, tmp = work[W.base], work[W.wn], work[W.tmp]
    torque_eval(tk, tP, tT, t, q, w, M0)
    for i in range(3):
        Pi[i] = I[i, 0] * w[0] + I[i, 1] * w[1] + I[i, 2] * w[2]
        g[i] = h * Pi[i] + 0.5 * h * h * M0[i]
        f[i] = 0.5 * h * w[i]
    converged = False
    last = np.inf
    for _ in range(LGVI_NEWTON):
        gf = g[0] * f[0] + g[1] * f[1] + g[2] * f[2]
        cross(g, f, tmp)
        for i in range(3):
            G[i] = 2.0 * (I[i, 0] * f[0] + I[i, 1] * f[1] + I[i, 2] * f[2]) - g[i] - tmp[i] - gf * f[i]
        for i in range(3):  # the Jacobian [g]x + f g^T + (g.f) E - 2 J, row-major
            for j in range(3):
                jac[3 * i + j] = f[i] * g[j] - 2.0 * I[i, j] + (gf if i == j else 0.0)
        jac[1] -= g[2]
        jac[2] += g[1]
        jac[3] += g[2]
        jac[5] -= g[0]
        jac[6] -= g[1]
        jac[7] += g[0]
        if not solve3(jac, G, df):
            return NOT_CONVERGED
        size = 0.0
        for i in range(3):
            f[i] += df[i]
            size += abs(df[i])
        scale = abs(f[0]) + abs(f[1]) + abs(f[2])
        # converged: the update at round-off, or no longer shrinking while within LGVI_STALL of f (the Jacobian's
        # round-off, eps times its condition: a pendulum's inertia about its pivot, moments 5.6e-4 to 4.7e-2, keeps
        # the update at 1.5e-15 of f; quadratic convergence halves it at least at every iteration before)
        if size <= 4e-16 * scale or (size >= 0.5 * last and size <= LGVI_STALL * scale):
            converged = True
            break
        last = size
    if not converged:
        return NOT_CONVERGED
    norm = np.sqrt(1.0 + f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    qf[0] = 1.0 / norm
    for i in range(3):
        qf[i + 1] = f[i] / norm
    qmul(q, qf, qn)
    for i in range(3):
        tmp[i] = Pi[i] + 0.5 * h * M0[i]
    rotate_back(qf, tmp, base)  # F^T (Pi_k + h/2 M_k)
    for i in range(3):
        M1[i] = M0[i]  # the start's torque: the first guess of the end's
    end_torque(t + h, qn, base, h, Iinv, tk, tP, tT, M1, M2, tmp, wn)
    for i in range(3):
        tmp[i] = base[i] + 0.5 * h * M1[i]
    n = np.sqrt(qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3])
    for i in range(4):
        y[i] = qn[i] / n
    for i in range(3):
        y[4 + i] = Iinv[i, 0] * tmp[0] + Iinv[i, 1] * tmp[1] + Iinv[i, 2] * tmp[2]
    return OK


# ------------------------------------------------------------------------------------------------
# splitting with the exact free flow (Celledoni, Fassò, Säfström & Zanna 2008)
# ------------------------------------------------------------------------------------------------
#: The triple jump's fractions of the step (Yoshida 1990, eq. 5.4): three Strang steps of 4th order together.
YOSHIDA4 = (1.0 / (2.0 - 2.0 ** (1.0 / 3.0)), 1.0 - 2.0 / (2.0 - 2.0 ** (1.0 / 3.0)), 1.0 / (2.0 - 2.0 ** (1.0 / 3.0)))


@ijit
def strang(t, y, h, I, Iinv, tk, tP, tT, work):
    """One Strang step (Celledoni, Fassò, Säfström & Zanna 2008, §5; ``Pi = J w`` the body momentum, ``M`` the
    body torque)::

        Pi <- Pi + h/2 M(t, q, w)                       (the kick: q held)
        (q, Pi) <- the exact free flow over h           (:func:`.freeflow.free_flow`)
        Pi <- Pi + h/2 M(t + h, q, J^-1 Pi_end)          (implicit in the end's rate, the first kick's adjoint)

    symmetric, so second order; symplectic where the torque has a potential (gravity, the gravity gradient), and
    torque free the exact flow itself. A torque that does not depend on the rate is evaluated once a step: the
    end's is the next start's. The end's body momentum is kept too and is the next start's (``J^-1`` then ``J`` again
    rounds it the same way at every step: a drift of 1e-16 a step in |Pi|, 1e-10 rad in the gyroscope's phase after
    41 000 steps). Both are kept in ``work`` with where they were taken; a start elsewhere computes them again.
    False, ``y`` untouched, where the free flow refuses the step (over its budget: :data:`.freeflow.MAX_TURN`)."""
    S, W = SPLIT_STATE, SPLIT_WORK
    q, w = y[S.p], y[S.w]
    V, J, ratios, Pi, Pe, dq, qn = work[W.V], work[W.J], work[W.ratios], work[W.Pi], work[W.Pe], work[W.dq], work[W.qn]
    M0, M1, M2, wn, cq, cw, cP = work[W.cM], work[W.M1], work[W.M2], work[W.wn], work[W.cq], work[W.cw], work[W.cP]
    if work[W.ready][0] == 0.0:
        principal_frame(I, work[W.A], V, J)
        work[W.ready][0] = 1.0
    same = (work[W.cached][0] != 0.0 and q[0] == cq[0] and q[1] == cq[1] and q[2] == cq[2] and q[3] == cq[3]
            and w[0] == cw[0] and w[1] == cw[1] and w[2] == cw[2])
    if not (same and work[W.ctorque][0] != 0.0 and work[W.ct][0] == t):
        torque_eval(tk, tP, tT, t, q, w, M0)
    for i in range(3):
        Pi[i] = (cP[i] if same else I[i, 0] * w[0] + I[i, 1] * w[1] + I[i, 2] * w[2]) + 0.5 * h * M0[i]
    if not free_flow(Pi, h, V, J, ratios, Pe, dq):
        return False
    qmul(q, dq, qn)  # q ⊗ (dq - 1): q + it is q ⊗ dq, rounded relative to the step's turn
    for i in range(4):
        qn[i] += q[i]
    n = np.sqrt(qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3])
    for i in range(4):
        q[i] = qn[i] / n
    for i in range(3):
        wn[i] = Iinv[i, 0] * Pe[0] + Iinv[i, 1] * Pe[1] + Iinv[i, 2] * Pe[2]
    torque_eval(tk, tP, tT, t + h, q, wn, M1)
    rate = torque_needs_rate(tk, tP)
    if rate:
        end_torque(t + h, q, Pe, h, Iinv, tk, tP, tT, M1, M2, Pi, wn)
    for i in range(3):
        cP[i] = Pe[i] + 0.5 * h * M1[i]
    for i in range(3):
        w[i] = Iinv[i, 0] * cP[0] + Iinv[i, 1] * cP[1] + Iinv[i, 2] * cP[2]
    work[W.cached][0] = 1.0
    work[W.ctorque][0] = 0.0 if rate else 1.0
    work[W.ct][0] = t + h
    for i in range(4):
        cq[i] = q[i]
    for i in range(3):
        cw[i] = w[i]
        M0[i] = M1[i]
    return True


@ijit
def split2_step(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, tk, tP, tT, axes, sing_tol, work):
    """The Strang splitting around the exact free flow (:func:`strang`): order 2."""
    return OK if strang(t, y, h, I, Iinv, tk, tP, tT, work) else OVER_BUDGET


@ijit
def split4_step(scheme, t, y, h, K, Y, Yhat, I, Iinv, A, b, c, tk, tP, tT, axes, sing_tol, work):
    """Yoshida's triple jump of :func:`strang` steps (fractions :data:`YOSHIDA4`, the middle one backwards in
    time): order 4, symmetric and, with a potential torque, symplectic (Yoshida 1990; Celledoni et al. 2008 §5)."""
    tc = t
    for k in range(3):
        hk = YOSHIDA4[k] * h
        if not strang(tc, y, hk, I, Iinv, tk, tP, tT, work):
            return OVER_BUDGET
        tc = tc + hk
    return OK
