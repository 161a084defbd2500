"""A batch of bodies in lockstep (Formulation II and the Lie-group method): the classical RK4 stage by stage over
blocks of :data:`LANES` bodies, the state as (component, body) arrays."""

from __future__ import annotations

import numpy as np

from ._variant import ijit, jit, stop_requested, torque_eval, torque_needs_attitude
from .registry import INTERRUPTED, NONFINITE, OK, SERIES_ANGLE
from .helpers import dexpinv_apply, dexpinv_coef_series, dexpinv_coef_trig, euler_rates, exp_coefs_series, exp_coefs_trig, f2_kinematics, qmul_s
from .schemes import F2, F2_STATE, FIRST, LIE, LIE_STATE, STATE_SIZE


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
#: The rows of the block's state are the components of the schemes' states (:data:`F2_STATE`, :data:`LIE_STATE`),
#: written out component by component in the scalar forms below; the rate's first row:
F2_W, LIE_W = F2_STATE.w.start, LIE_STATE.w.start


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
    lanes_torque(t, S, lanes_attitude_f2, tk, tP, tT, tau, q, out, nb, F2_W)
    for k in range(nb):
        D[0, k], D[1, k], D[2, k], D[3, k] = f2_kinematics(S[0, k], S[1, k], S[2, k], S[3, k], S[4, k], S[5, k],
                                                           S[6, k])
    lanes_rates(S, D, IL, JL, shared, k0, tau, nb, F2_W)


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
    lanes_torque(t, S, lanes_attitude_lie, tk, tP, tT, tau, q, out, nb, LIE_W)
    for k in range(nb):
        a2 = S[4, k] * S[4, k] + S[5, k] * S[5, k] + S[6, k] * S[6, k]
        C[4, k] = a2
        C[0, k] = dexpinv_coef_series(a2)
    for k in range(nb):
        if C[4, k] >= SERIES_ANGLE * SERIES_ANGLE:
            C[0, k] = dexpinv_coef_trig(C[4, k])
    for k in range(nb):
        D[4, k], D[5, k], D[6, k] = dexpinv_apply(S[4, k], S[5, k], S[6, k], S[7, k], S[8, k], S[9, k], C[0, k])
    lanes_rates(S, D, IL, JL, shared, k0, tau, nb, LIE_W)


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
        stopped = stop_requested(a.stop)
        for k in range(nb):
            if status[k0 + k] != OK:
                continue
            for l in range(m):
                if not np.isfinite(Y[l, k]):
                    status[k0 + k] = NONFINITE
            if stopped and status[k0 + k] == OK:
                status[k0 + k] = INTERRUPTED
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
        if stopped:
            return
    for k in range(nb):
        if status[k0 + k] == OK:
            steps_done[k0 + k] = n
