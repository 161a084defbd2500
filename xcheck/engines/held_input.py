"""Compiled code for the inputs engines take from xcheck: a Basilisk module that writes a precomputed input before
every task step (the held inputs of :mod:`xcheck.engines.basilisk` without a Python call per step), and the torque
PyBullet, DART, Drake and EXUDYN apply, in world components from their own states (:func:`engine_torque`).

Basilisk's ``NumbaModel`` runs a C function (``void f(void **ptrs, uint64 CurrentSimNanos)``) at every task call
of its module, with ``ptrs`` the pointers its owner registered: here ``ptrs[0]`` the payload of the message it
writes (three doubles at its start: ``magField_N`` of a ``MagneticFieldMsg``, ``torqueRequestBody`` of a
``CmdTorqueBodyMsg``), ``ptrs[1]`` two int64 ``[n, ns]`` (the number of steps and the task step in
nanoseconds) and ``ptrs[2]`` the table ``(n, 3)`` of the values, row ``k`` for the step from ``k ns`` to
``(k + 1) ns``. At the call for ``CurrentSimNanos = (k + 1) ns`` (the hub then integrates that step) it writes
row ``k``; before the first step and after the last it writes nothing. Basilisk marks the message written.

One function for every run (the table's length is read at run time), compiled once and cached like the
integrators (:mod:`xcheck._jit`); Python takes no part while the simulation runs. Measured on the RAX-1 orbit
field: 80 us a step with a Python ``SysModel`` writing the field, 12 us with this module (the torque-free hub's
own cost), the same numbers bit for bit.
"""

from __future__ import annotations

import numpy as np

from .._jit import numba
from ..fields.kernel import torque_eval, world_to_body
from ..integrators.kernels.helpers import dcm_to_quat, qmul, quat_exp

__all__ = ["write_row", "SIGNATURE", "world_torque", "engine_torque"]

#: ``void(void **ptrs, uint64 CurrentSimNanos)``, Basilisk's ``NumbaModel`` update function.
SIGNATURE = numba.types.void(numba.types.CPointer(numba.types.voidptr), numba.types.uint64)


@numba.cfunc(SIGNATURE, cache=True)
def write_row(ptrs, nanos):
    meta = numba.carray(ptrs[1], 2, np.int64)
    n, ns = meta[0], meta[1]
    k = np.int64(nanos) // ns - 1
    if k < 0 or k >= n:
        return
    table = numba.carray(ptrs[2], (n, 3), np.float64)
    out = numba.carray(ptrs[0], 3, np.float64)
    out[0] = table[k, 0]
    out[1] = table[k, 1]
    out[2] = table[k, 2]


# ------------------------------------------------------------------------------------------------------------------
# The torque an engine applies in world components, from the engine's own state (PyBullet, DART, Drake, EXUDYN)
# ------------------------------------------------------------------------------------------------------------------
#: How an engine gives its attitude (:func:`world_torque`'s ``form``): a quaternion scalar first (Drake's), scalar
#: last (Bullet's), a row-major rotation matrix (EXUDYN's), or a rotation vector (DART's FreeJoint positions), body ->
#: world.
WXYZ, XYZW, DCM, ROTVEC = 0, 1, 2, 3
_FORMS = {"wxyz": WXYZ, "xyzw": XYZW, "dcm": DCM, "rotvec": ROTVEC}


@numba.njit(cache=True, error_model="numpy")
def world_torque(kind, P, T, t, att, form, right, w, rates_world, out):
    """The torque of the model ``(kind, P, T)`` (:func:`xcheck.fields.torque_eval`) in world components, from an
    engine's state: its attitude ``att`` in ``form`` (:data:`WXYZ`, :data:`XYZW`, :data:`DCM` row-major or
    :data:`ROTVEC`, flat) of a frame whose attitude relative to the body is ``right`` (the body is ``att ⊗ right``: a
    principal frame's ``conj(q_V)``, else the identity), its rate ``w`` in world components (``rates_world``) or body
    components. One compiled call a step instead of a dozen small numpy ones (270 us a step on RAX-1's field, 20 with
    this), written with the kernels' own quaternion helpers."""
    a = np.empty(4)
    if form == DCM:
        dcm_to_quat(att, a)
    elif form == ROTVEC:
        quat_exp(att, a)
    elif form == XYZW:
        a[0], a[1], a[2], a[3] = att[3], att[0], att[1], att[2]
    else:
        a[:] = att[:4]
    q = np.empty(4)
    qmul(a, right, q)
    q /= np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    wb = np.empty(3)
    if rates_world:
        wb[0], wb[1], wb[2] = world_to_body(q, w[0], w[1], w[2])
    else:
        wb[:] = w[:3]
    tau = np.empty(3)
    torque_eval(kind, P, T, t, q, wb, tau)
    conj = np.empty(4)  # R tau = R(conj q)^T tau
    conj[0], conj[1], conj[2], conj[3] = q[0], -q[1], -q[2], -q[3]
    out[0], out[1], out[2] = world_to_body(conj, tau[0], tau[1], tau[2])


def engine_torque(torque, *, form: str, right=None, rates: str):
    """``f(t, att, w) -> (3,)``: ``torque`` (a :class:`~xcheck.fields.TorqueModel`, or any ``(t, q, omega) -> (3,)``
    of body components) as an engine applies it, in world components, from the engine's attitude ``att`` (``form``:
    "wxyz", "xyzw", "dcm" or "rotvec") of a frame ``right`` off the body (see :func:`world_torque`) and its rate ``w``
    (``rates``: "world" or "body" components), both float arrays. A torque model is evaluated compiled; another
    callable through :mod:`xcheck.rotations` (the same numbers to round-off)."""
    from .. import rotations as rot
    from ..fields import TorqueModel

    if form not in _FORMS or rates not in ("world", "body"):
        raise ValueError(f"form/rates: expected one of {', '.join(_FORMS)} / 'world' or 'body', got {form!r}/{rates!r}")
    right = np.array([1.0, 0.0, 0.0, 0.0]) if right is None else np.ascontiguousarray(right, dtype=float)
    code, in_world = _FORMS[form], rates == "world"
    if isinstance(torque, TorqueModel):
        kind, P, T = torque.kernel_data()

        def compiled(t, att, w):  # att and w: float arrays (the engines' rows), called at every step or stage
            out = np.empty(3)
            world_torque(kind, P, T, t, att.reshape(-1), code, right, w, in_world, out)
            return out
        return compiled

    def interpreted(t, att, w):
        att = np.asarray(att, dtype=float)
        a = (rot.dcm_to_quat(att.reshape(3, 3)) if code == DCM else rot.rotvec_to_quat(att) if code == ROTVEC else
             np.concatenate([att[3:], att[:3]]) if code == XYZW else att)
        q = rot.quat_mul(a, right)
        q = q / np.linalg.norm(q)
        wb = rot.quat_rotate(rot.quat_conj(q), w) if in_world else np.asarray(w, dtype=float)
        return rot.quat_rotate(q, np.asarray(torque(t, q, wb), dtype=float))
    return interpreted
