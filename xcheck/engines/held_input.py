"""A Basilisk module in compiled code that writes a precomputed input before every task step: the held inputs
of :mod:`xcheck.engines.basilisk` without a Python call per step.

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

__all__ = ["write_row", "SIGNATURE"]

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
