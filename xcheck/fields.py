"""Torque models as data: what the integrators' compiled kernels evaluate at every stage.

A torque model is a small object holding plain arrays: an integer *kind*, a parameter vector ``P`` and a
table ``T``. :func:`torque_eval` (compiled with numba) evaluates any model from that data without a Python
call per stage, and every model is also a Python callable ``model(t, q, omega) -> (3,)`` [N m] (the same
compiled function) for scipy, MuJoCo's callback and plotting. Any other Python callable with that
signature is accepted by :func:`xcheck.integrators.integrate` too, on a slower, interpreted path.

Magnetic torque (seed 004 eq. 174): ``t' = mu0 (M_p x H)`` in body components, ``H`` the field strength
[A/m] in body components, ``M_p`` the permanent dipole [A m^2], ``mu0 = 4 pi 1e-7`` H/m; ``B = mu0 H`` [T].
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "MU0",
    "TorqueModel",
    "ConstantTorque",
    "MagneticTorque",
    "BodyFieldTable",
    "UniformField",
    "torque_eval",
    "magnetic_torque",
]

#: Vacuum permeability [H/m] as used by seed 004 eq. 174.
MU0 = 4e-7 * np.pi

# kernel kinds
FREE = 0
CONSTANT = 1
MAGNETIC = 2
# field kinds (P[3] of a magnetic model)
FIELD_BODY_TABLE = 0
FIELD_UNIFORM = 1


@njit(cache=True, error_model="numpy")
def _interp_rows(T, t):
    """Linear interpolation of the table columns 1-3 at time ``t`` (column 0 ascending), as a tuple."""
    n = T.shape[0]
    i = np.searchsorted(T[:, 0], t, side="right") - 1
    if i < 0:
        i = 0
    if i > n - 2:
        i = n - 2
    s = (t - T[i, 0]) / (T[i + 1, 0] - T[i, 0])
    return (T[i, 1] + s * (T[i + 1, 1] - T[i, 1]),
            T[i, 2] + s * (T[i + 1, 2] - T[i, 2]),
            T[i, 3] + s * (T[i + 1, 3] - T[i, 3]))


@njit(cache=True, error_model="numpy")
def _world_to_body(q, vx, vy, vz):
    """``R(q)^T v`` for a (not necessarily unit) quaternion ``q`` [w, x, y, z], normalised here."""
    n = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w = q[0] / n
    x = -q[1] / n  # rotation by the conjugate: u = -vec(q)
    y = -q[2] / n
    z = -q[3] / n
    # v + 2 w (u x v) + 2 u x (u x v)
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty),
            vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


@njit(cache=True, error_model="numpy")
def _field_body(P, T, t, q):
    """Field strength H [A/m] in body components for the field described by ``P[3:]`` and ``T``."""
    kind = int(P[3])
    if kind == FIELD_BODY_TABLE:
        return _interp_rows(T, t)
    # FIELD_UNIFORM: H fixed in world components, P[4:7]
    return _world_to_body(q, P[4], P[5], P[6])


@njit(cache=True, error_model="numpy")
def torque_eval(kind, P, T, t, q, w, out):
    """Body-frame torque [N m] of the model ``(kind, P, T)`` at time ``t`` [s], attitude ``q`` [w, x, y, z]
    (body -> world, normalised here) and body rate ``w`` [rad/s]; written into ``out`` (3,)."""
    if kind == FREE:
        out[0] = 0.0
        out[1] = 0.0
        out[2] = 0.0
    elif kind == CONSTANT:
        out[0] = P[0]
        out[1] = P[1]
        out[2] = P[2]
    else:  # MAGNETIC: seed 004 eq. 174, t' = mu0 (M_p x H)
        hx, hy, hz = _field_body(P, T, t, q)
        out[0] = MU0 * (P[1] * hz - P[2] * hy)
        out[1] = MU0 * (P[2] * hx - P[0] * hz)
        out[2] = MU0 * (P[0] * hy - P[1] * hx)


@njit(cache=True, error_model="numpy")
def torque_needs_attitude(kind, P):
    """Whether the model's torque depends on the attitude (kernels skip computing it otherwise)."""
    return kind == MAGNETIC and int(P[3]) != FIELD_BODY_TABLE


def magnetic_torque(dipole, H_body):
    """``mu0 (M_p x H)`` (seed 004 eq. 174) for stacks ``(..., 3)``: dipole [A m^2], H [A/m] -> [N m]."""
    return MU0 * np.cross(np.asarray(dipole, float), np.asarray(H_body, float))


_EMPTY_TABLE = np.zeros((0, 4))


class TorqueModel:
    """A torque as data. Subclasses set ``kind``, ``P`` (1-D float array) and ``T`` (2-D float array)."""

    kind: int = FREE
    P: np.ndarray = np.zeros(3)
    T: np.ndarray = _EMPTY_TABLE
    attitude_dependent: bool = False

    def kernel_data(self) -> tuple[int, np.ndarray, np.ndarray]:
        return self.kind, self.P, self.T

    def __call__(self, t, q, omega) -> np.ndarray:
        out = np.empty(3)
        torque_eval(self.kind, self.P, self.T, float(t), np.ascontiguousarray(q, dtype=float),
                    np.ascontiguousarray(omega, dtype=float), out)
        return out

    def check_span(self, t_end: float) -> None:
        """Raise ValueError if the model is not defined on ``[0, t_end]``."""

    def describe(self) -> str:
        return type(self).__name__


class ConstantTorque(TorqueModel):
    """A constant torque in body components [N m]."""

    kind = CONSTANT

    def __init__(self, torque_body):
        tb = np.asarray(torque_body, dtype=float)
        if tb.shape != (3,) or not np.all(np.isfinite(tb)):
            raise ValueError(f"torque_body: expected a finite (3,) vector in N m, got {torque_body!r}")
        self.P = tb.copy()

    def describe(self) -> str:
        return f"constant body torque {self.P.tolist()} N m"


class BodyFieldTable:
    """A field strength time series in body components (CSV columns t [s], Hx, Hy, Hz [A/m]), linearly
    interpolated: the torque does not depend on attitude (seed 004 §3.2, the thesis's set-up)."""

    kind = FIELD_BODY_TABLE
    attitude_dependent = False

    def __init__(self, table, *, source: str = "table"):
        T = np.asarray(table, dtype=float)
        if T.ndim != 2 or T.shape[1] != 4 or T.shape[0] < 2:
            raise ValueError(f"{source}: expected rows of 4 columns (t [s], Hx, Hy, Hz [A/m]) and at least 2 rows, "
                             f"got shape {T.shape}")
        if not np.all(np.isfinite(T)):
            raise ValueError(f"{source}: contains non-finite values")
        if not np.all(np.diff(T[:, 0]) > 0):
            raise ValueError(f"{source}: the time column must be strictly increasing")
        self.T = np.ascontiguousarray(T)
        self.source = source

    def params(self) -> np.ndarray:
        return np.array([float(self.kind)])

    def check_span(self, t_end: float) -> None:
        t0, t1 = self.T[0, 0], self.T[-1, 0]
        if t0 > 0 or t1 < t_end:
            raise ValueError(f"{self.source}: the field table covers {t0:g} to {t1:g} s; the run needs 0 to "
                             f"{t_end:g} s (times outside a table are an error, not an extrapolation)")

    def H_body(self, t) -> np.ndarray:
        """Field strength [A/m] in body components at times ``t`` (...,) -> (..., 3)."""
        t = np.asarray(t, dtype=float)
        return np.stack([np.interp(t, self.T[:, 0], self.T[:, k]) for k in (1, 2, 3)], axis=-1)

    def describe(self) -> str:
        return f"body-frame field table {self.source} ({self.T.shape[0]} rows, {self.T[0, 0]:g}-{self.T[-1, 0]:g} s)"


class UniformField:
    """A field fixed in inertial space (world components, [A/m]): the torque depends on attitude."""

    kind = FIELD_UNIFORM
    attitude_dependent = True

    def __init__(self, H_world):
        H = np.asarray(H_world, dtype=float)
        if H.shape != (3,) or not np.all(np.isfinite(H)):
            raise ValueError(f"H_world: expected a finite (3,) vector in A/m, got {H_world!r}")
        self.H_world = H
        self.T = _EMPTY_TABLE

    def params(self) -> np.ndarray:
        return np.concatenate([[float(self.kind)], self.H_world])

    def check_span(self, t_end: float) -> None:
        pass

    def describe(self) -> str:
        return f"uniform inertial field {self.H_world.tolist()} A/m"


class MagneticTorque(TorqueModel):
    """Seed 004 eq. 174: ``t' = mu0 (M_p x H_body)`` for a permanent dipole in a field model."""

    kind = MAGNETIC

    def __init__(self, dipole, field):
        d = np.asarray(dipole, dtype=float)
        if d.shape != (3,) or not np.all(np.isfinite(d)):
            raise ValueError(f"dipole: expected a finite (3,) vector in A m^2, got {dipole!r}")
        self.dipole = d
        self.field = field
        self.P = np.concatenate([d, field.params()])
        self.T = np.ascontiguousarray(field.T) if field.T.size else _EMPTY_TABLE
        self.attitude_dependent = field.attitude_dependent

    def check_span(self, t_end: float) -> None:
        self.field.check_span(t_end)

    def describe(self) -> str:
        return f"magnetic dipole {self.dipole.tolist()} A m^2 in {self.field.describe()}"
