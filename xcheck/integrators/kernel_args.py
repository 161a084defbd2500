"""The named arguments of the integrator kernels (one record instead of a positional tuple).

Defined in a module of its own, outside :mod:`.kernels`, so that both variants of the kernels (compiled,
interpreted) see the same class: numba's cache stores signatures that name it."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["KernelArgs"]


class KernelArgs(NamedTuple):
    """What a run needs besides its state and inertia (read by field name inside the kernels)."""

    A: np.ndarray  # (s, s) Butcher matrix
    b: np.ndarray  # (s,) weights
    c: np.ndarray  # (s,) nodes
    dt: float  # [s]
    n: int  # steps
    last_h: float  # the last step's length [s]
    tk: object  # torque kind (int) of xcheck.fields, or a Python callable (interpreted kernels)
    tP: np.ndarray  # torque parameters
    tT: np.ndarray  # torque table
    axes: np.ndarray  # (3,) Euler sequence axes, 0-based
    sing_tol: float  # Euler-angle singularity threshold on |det J|
    bjorck_tol: float  # Björck-Bowie stopping tolerance
    save_every: int  # store every this many steps (and the last)
    stop: np.ndarray  # (1,) int64: the loop returns INTERRUPTED once it is nonzero (xcheck.base.interrupts.stop_flag)
