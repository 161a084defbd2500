"""The registry of our integrators: name -> what it integrates, from which seed, at what order, and how
its state is built from ``(q0, omega0)`` and read back as ``(q, omega)``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import rotations as rot
from ..trajectory import continuous_quaternions
from . import _kernels as K
from .tableau import RK4, THESIS_172_DEXP_A, ButcherTableau

__all__ = ["Method", "METHODS"]


@dataclass(frozen=True)
class Method:
    """One integrator.

    ``kernel`` is the state layout of :mod:`xcheck.integrators._kernels` (None: not a fixed-step
    kernel method); ``expected_order`` None means adaptive (no order in the step).
    """

    name: str
    kernel: int | None
    expected_order: int | None
    summary: str
    seed: str
    tableau: ButcherTableau = RK4
    dexp_A: tuple | None = None
    encode: Callable | None = None
    decode: Callable | None = None


# ------------------------------------------------------------------------------------------------
# state <-> (q, omega) on stacks: q0 (..., 4), w0 (..., 3) -> y0 (..., m); y (n, m) -> q, omega, extras
# ------------------------------------------------------------------------------------------------
def _enc_euler(q0, w0, seq):
    return np.concatenate([rot.quat_to_euler(q0, seq, warn=False), w0], axis=-1)


def _dec_euler(y, seq):
    angles = y[:, 0:3]
    return continuous_quaternions(rot.euler_to_quat(angles, seq)), y[:, 3:6], {"euler": angles.copy()}


def _enc_f1(q0, w0, seq):
    return np.concatenate([q0, rot.quat_rate(q0, w0)], axis=-1)  # p'0 = 1/2 G(p0)^T w0 (eq. 162)


def _dec_f1(y, seq):
    p, pd = y[:, 0:4], y[:, 4:8]
    omega = 2 * rot.quat_mul(rot.quat_conj(p), pd)[:, 1:]  # w' = 2 G(p) p' (eq. 140)
    return p.copy(), omega, {}


def _enc_f2(q0, w0, seq):
    return np.concatenate([q0, w0], axis=-1)


def _dec_f2(y, seq):
    return y[:, 0:4].copy(), y[:, 4:7].copy(), {}


def _enc_local(q0, w0, seq):
    return np.concatenate([q0, np.zeros_like(w0), w0], axis=-1)


def _dec_lie(y, seq):
    return y[:, 0:4].copy(), y[:, 7:10].copy(), {}


def _enc_dcm(q0, w0, seq):
    R = rot.quat_to_dcm(q0)
    return np.concatenate([R.reshape(R.shape[:-2] + (9,)), w0], axis=-1)


def _dec_dcm(y, seq):
    R = y[:, 0:9].reshape(-1, 3, 3)
    ortho = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-2, -1))
    return continuous_quaternions(rot.dcm_to_quat(R)), y[:, 9:12].copy(), {"orthogonality": ortho}


def _dec_local(to_quat):
    """Decoder of a local-chart state ``q_ref(4), v(3), w(3)``: attitude ``q_ref ⊗ to_quat(v)``."""
    def decode(y, seq):
        q = rot.quat_mul(y[:, 0:4], to_quat(y[:, 4:7]))
        return continuous_quaternions(q), y[:, 7:10].copy(), {}
    return decode


_dec_gibbs = _dec_local(rot.gibbs_to_quat)
_dec_rotvec = _dec_local(rot.rotvec_to_quat)


METHODS: dict[str, Method] = {m.name: m for m in [
    Method("euler-rk4", K.EULER, 4, "RK4 on Euler angles and Euler's equations (any of the 12 sequences)",
           "seed 001, appendix A", encode=_enc_euler, decode=_dec_euler),
    Method("formulation-1", K.F1, 4, "RK4 on the quaternion DAE at acceleration level; normalise p, project p'",
           "seed 004 §2.3, eq. 150-157", encode=_enc_f1, decode=_dec_f1),
    Method("formulation-2", K.F2, 4, "RK4 on (p, w'), p' = 1/2 G^T w'; normalise p",
           "seed 004 §2.4, eq. 158-163", encode=_enc_f2, decode=_dec_f2),
    Method("lie-rkmk4", K.LIE, 4, "Runge-Kutta-Munthe-Kaas 4 on so(3) with dexp^-1 and exp_S3 (unit norm by "
           "construction)", "seed 004 §2.5, eq. 166-172 (third stage corrected)", encode=_enc_local, decode=_dec_lie),
    Method("lie-thesis-172", K.LIE, 2, "seed 004 algorithm 172 as printed (1/2 k1 in the third stage's dexp^-1)",
           "seed 004 §2.5, eq. 172", dexp_A=THESIS_172_DEXP_A, encode=_enc_local, decode=_dec_lie),
    Method("dcm-rk4", K.DCM, 4, "RK4 on R' = R [w x]; Björck-Bowie orthonormalisation after each step",
           "seed 000 eq. 1.7, §1.7.1", encode=_enc_dcm, decode=_dec_dcm),
    Method("gibbs-rk4", K.GIBBS, 4, "RK4 on the Gibbs vector (chart re-centred beyond 90 deg)",
           "seed 000 §1.4", encode=_enc_local, decode=_dec_gibbs),
    Method("rotvec-rk4", K.ROTVEC, 4, "RK4 on the rotation vector with the non-commutativity term (chart "
           "re-centred beyond 180 deg)", "seed 000 §1.5", encode=_enc_local, decode=_dec_rotvec),
    Method("scipy-rk45", None, None, "scipy solve_ivp RK45, default tolerances (rtol 1e-3, atol 1e-6), sampled "
           "on the grid", "seed 001, appendix A (its own choice)"),
]}
