"""Compiled code for the inputs engines take from xcheck: a Basilisk module that writes a precomputed input before
every task step (the held inputs of :mod:`xcheck.engines.basilisk` without a Python call per step), and the torque
PyBullet, DART and Drake apply, in world components from their own states (:func:`engine_torque`).

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
from ..fields.kernel import torque_eval

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
# The torque an engine applies in world components, from the engine's own state (PyBullet, DART, Drake)
# ------------------------------------------------------------------------------------------------------------------
#: How an engine gives its attitude (:func:`world_torque`'s ``form``): a quaternion scalar first (Drake's), scalar
#: last (Bullet's), a row-major rotation matrix, or a rotation vector (DART's FreeJoint positions), body -> world.
WXYZ, XYZW, DCM, ROTVEC = 0, 1, 2, 3
_FORMS = {"wxyz": WXYZ, "xyzw": XYZW, "dcm": DCM, "rotvec": ROTVEC}


@numba.njit(cache=True, error_model="numpy")
def world_torque(kind, P, T, t, att, form, right, w, rates_world, out):
    """The torque of the model ``(kind, P, T)`` (:func:`xcheck.fields.torque_eval`) in world components, from an
    engine's state: its attitude ``att`` in ``form`` (:data:`WXYZ`, :data:`XYZW` or :data:`DCM`, flat) of a frame
    whose attitude relative to the body is ``right`` (the body is ``att ⊗ right``: a principal frame's
    ``conj(q_V)``, else the identity), its rate ``w`` in world components (``rates_world``) or body components.
    One compiled call a step instead of a dozen small numpy ones (270 us a step on RAX-1's field, 20 with this)."""
    a = np.empty(4)
    if form == DCM:  # Shepperd's method (xcheck.rotations.dcm_to_quat)
        tr = att[0] + att[4] + att[8]
        if tr >= att[0] and tr >= att[4] and tr >= att[8]:
            a[0], a[1], a[2], a[3] = 1.0 + tr, att[7] - att[5], att[2] - att[6], att[3] - att[1]
        elif att[0] >= att[4] and att[0] >= att[8]:
            a[0], a[1], a[2], a[3] = att[7] - att[5], 1.0 + 2.0 * att[0] - tr, att[1] + att[3], att[2] + att[6]
        elif att[4] >= att[8]:
            a[0], a[1], a[2], a[3] = att[2] - att[6], att[1] + att[3], 1.0 + 2.0 * att[4] - tr, att[5] + att[7]
        else:
            a[0], a[1], a[2], a[3] = att[3] - att[1], att[2] + att[6], att[5] + att[7], 1.0 + 2.0 * att[8] - tr
    elif form == XYZW:
        a[0], a[1], a[2], a[3] = att[3], att[0], att[1], att[2]
    elif form == ROTVEC:  # exp of the rotation vector (xcheck.rotations.rotvec_to_quat)
        angle = np.sqrt(att[0] * att[0] + att[1] * att[1] + att[2] * att[2])
        half = 0.5 * angle
        s = 0.5 - angle * angle / 48.0 if angle < 1e-4 else np.sin(half) / angle  # sin(angle/2) / angle
        a[0], a[1], a[2], a[3] = np.cos(half), s * att[0], s * att[1], s * att[2]
    else:
        a[0], a[1], a[2], a[3] = att[0], att[1], att[2], att[3]
    q = np.empty(4)  # a ⊗ right, normalised
    q[0] = a[0] * right[0] - a[1] * right[1] - a[2] * right[2] - a[3] * right[3]
    q[1] = a[0] * right[1] + a[1] * right[0] + a[2] * right[3] - a[3] * right[2]
    q[2] = a[0] * right[2] - a[1] * right[3] + a[2] * right[0] + a[3] * right[1]
    q[3] = a[0] * right[3] + a[1] * right[2] - a[2] * right[1] + a[3] * right[0]
    q /= np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    R = np.empty((3, 3))  # body -> world
    w0, x, y, z = q[0], q[1], q[2], q[3]
    R[0, 0], R[0, 1], R[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w0 * z), 2 * (x * z + w0 * y)
    R[1, 0], R[1, 1], R[1, 2] = 2 * (x * y + w0 * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w0 * x)
    R[2, 0], R[2, 1], R[2, 2] = 2 * (x * z - w0 * y), 2 * (y * z + w0 * x), 1 - 2 * (x * x + y * y)
    wb = np.empty(3)
    for i in range(3):
        wb[i] = R[0, i] * w[0] + R[1, i] * w[1] + R[2, i] * w[2] if rates_world else w[i]
    tau = np.empty(3)
    torque_eval(kind, P, T, t, q, wb, tau)
    for i in range(3):
        out[i] = R[i, 0] * tau[0] + R[i, 1] * tau[1] + R[i, 2] * tau[2]


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
