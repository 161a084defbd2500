"""The steps: a scheme's derivative and hooks chosen at compile time (:func:`deriv`, :func:`before_step`,
:func:`after_step`), the Runge-Kutta stage loop generated from each tableau's exact fractions (:func:`rk_step_for`),
and the commutator-free step (:func:`cf4_step`)."""

from __future__ import annotations

import inspect

import numpy as np

from ..tableau import RK4
from ._variant import PYTHON_MODE, ijit, numba, overload
from .registry import OK, SCHEMES
from .helpers import qmul, quat_exp
from .schemes import CF4_WORK, FIRST, LIE_STATE, STATE_SIZE  # noqa: F401 (read by the generated steps' source, and the schemes declared first)


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
