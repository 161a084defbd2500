"""Which variant of the kernels this package is, and what that changes: the compiled one (numba's ``jit``, the
torque evaluated by :mod:`xcheck.fields.kernel`) or the interpreted twin (``jit`` the identity, the torque a Python
callable) that :func:`xcheck.integrators._kernels_for` loads from the same files under another package name, with
``VARIANT`` set on the package before its modules run."""

from __future__ import annotations

import sys

import numpy as np


#: Which variant this module is: set by the loader before the module runs (``_kernels_for``); the module
#: imported normally is the compiled one.
VARIANT = getattr(sys.modules[__name__.rpartition(".")[0]], "VARIANT", "compiled")
if VARIANT not in ("compiled", "python"):
    raise ImportError(f"{__name__}: unknown variant {VARIANT!r}")
PYTHON_MODE = VARIANT == "python"

if PYTHON_MODE:  # the interpreted twin: same code, Python torque callables

    def jit(f):
        return f

    pjit = ijit = jit
    prange = range

    def stop_requested(flag):
        return flag[0] != 0

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

    def torque_needs_rate(kind, P):
        return True

    numba = overload = None

else:
    import warnings

    from numba.extending import overload  # noqa: F401 (the steps' dispatch)

    from ... import fields
    from ..._jit import (
        numba,  # numba with xcheck's cache folder (outside the installed package)
        stop_requested,  # noqa: F401 (the loops' poll of the stop flag)
    )

    # numba's pedantic SSA check misfires on IR-inlined code ("variable ... is not in scope"); harmless
    warnings.filterwarnings("ignore", category=numba.core.errors.NumbaIRAssumptionWarning)

    # jit: a helper compiled once and called; ijit: inlined where it is used (see the module docstring).
    # Neither uses numba's runtime: no allocation, no reference counts (numba refuses code that would).
    # Every entry point releases the interpreter's lock while it runs: the thread that sets the stop flag on Ctrl-C
    # needs it (xcheck.base.interrupts).
    jit = numba.njit(cache=True, error_model="numpy", _nrt=False, nogil=True)
    ijit = numba.njit(cache=True, error_model="numpy", inline="always", _nrt=False)
    pjit = numba.njit(cache=True, parallel=True, error_model="numpy", nogil=True)
    prange = numba.prange
    torque_eval = fields.torque_eval  # inlined (its evaluators are calls)
    torque_needs_attitude = fields.torque_needs_attitude
    torque_needs_rate = fields.torque_needs_rate
