"""Rigid bodies: a validated inertia tensor, its principal axes, mass and permanent magnetic dipole."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["RigidBody", "validate_inertia", "principal_axes", "TRIANGLE_RTOL", "MOMENT_RANGE", "MAX_RATE",
           "MAX_GRAVITY"]

#: Relative slack allowed in the triangle inequality ``I_i <= I_j + I_k``, so that thin plates
#: (``I_3 = I_1 + I_2`` exactly, like the seed 001 gyroscope) pass after rounding.
TRIANGLE_RTOL = 1e-9

_NAMES = ("I1", "I2", "I3")
#: Principal moments [kg m^2] xcheck integrates: a dust grain's to a moon's. Beyond, the energy and momentum products
#: of the references under- or overflow (1e-300 once ran a sweep's cell into NaN warnings instead of a refusal).
MOMENT_RANGE = (1e-30, 1e40)
#: The fastest body rate and wheel speed [rad/s] xcheck takes (about a million rpm: past any spinning machine, an
#: ultracentrifuge's 1e4 rad/s included). Beyond, a step that resolves the motion underflows the duration's
#: resolution, and 1e300 overflowed the energy into NaN deep inside a derivation.
MAX_RATE = 1e5
#: The strongest gravity [m/s^2] a top may turn in: a thousand g (a top in a centrifuge). 1e300 overflowed its
#: torque into NaN.
MAX_GRAVITY = 1e4


def validate_inertia(inertia, *, name: str = "inertia") -> np.ndarray:
    """Return the body-frame inertia tensor ``(3, 3)`` [kg m^2] of principal moments ``(3,)`` or a tensor.

    A physical rigid body has positive principal moments that satisfy the triangle inequality
    ``I_i <= I_j + I_k`` (equality for a thin plate). Anything else is a :class:`ValueError` saying
    which moment fails. (Tensors that passed are remembered: a study checks the same one at every run.)
    """
    if isinstance(inertia, np.ndarray) and inertia.dtype == float and inertia.shape in ((3,), (3, 3)):
        known = _VALID.get((inertia.shape, inertia.tobytes()))
        if known is not None:
            return known.copy()
    tensor = _validate_inertia(inertia, name)
    if len(_VALID) > 256:
        _VALID.clear()
    a = np.asarray(inertia, dtype=float)
    _VALID[(a.shape, a.tobytes())] = tensor.copy()
    return tensor


_VALID: dict = {}


def _validate_inertia(inertia, name: str) -> np.ndarray:
    try:
        a = np.asarray(inertia, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected principal moments (3,) or a tensor (3, 3) in kg m^2") from exc
    if a.shape == (3,):
        tensor = np.diag(a)
        moments = a
    elif a.shape == (3, 3):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: contains non-finite values")
        scale = np.abs(a).max()
        if not np.allclose(a, a.T, rtol=0, atol=1e-12 * max(scale, 1e-300)):
            raise ValueError(f"{name}: the tensor is not symmetric")
        tensor = 0.5 * (a + a.T)
        moments = np.linalg.eigvalsh(tensor)
    else:
        raise ValueError(f"{name}: expected principal moments (3,) or a tensor (3, 3), got shape {a.shape}")
    if not np.all(np.isfinite(moments)):
        raise ValueError(f"{name}: contains non-finite values")
    for i in range(3):
        if not moments[i] > 0:
            raise ValueError(f"{name}: principal moment {_NAMES[i]} = {moments[i]:g} kg m^2 must be positive")
        if not MOMENT_RANGE[0] <= moments[i] <= MOMENT_RANGE[1]:
            raise ValueError(f"{name}: principal moment {_NAMES[i]} = {moments[i]:g} kg m^2 is outside "
                             f"{MOMENT_RANGE[0]:g} … {MOMENT_RANGE[1]:g} kg m^2, where the dynamics' products "
                             "(momentum squared, energy times a moment) stay within double precision")
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        if moments[i] > (moments[j] + moments[k]) * (1 + TRIANGLE_RTOL):
            raise ValueError(
                f"{name}: principal moment {_NAMES[i]} = {moments[i]:g} exceeds {_NAMES[j]} + {_NAMES[k]} = "
                f"{moments[j] + moments[k]:g} kg m^2 (triangle inequality: no rigid body has such inertia)")
    return tensor


def principal_axes(tensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments ``(3,)`` (ascending) and a proper rotation ``V`` (columns = principal axes in
    body components, ``det V = +1``) with ``tensor = V @ diag(moments) @ V.T``.

    A diagonal tensor keeps its axes (in ascending order of moment, the order of equal moments kept).
    """
    tensor = np.asarray(tensor, dtype=float)
    if np.count_nonzero(tensor - np.diag(np.diag(tensor))) == 0:
        moments = np.diag(tensor).copy()
        order = np.argsort(moments, kind="stable")
        V = np.eye(3)[:, order]
        moments = moments[order]
    else:
        moments, V = np.linalg.eigh(tensor)
    if np.linalg.det(V) < 0:
        V[:, 2] = -V[:, 2]
    return moments, V


@dataclass(frozen=True)
class RigidBody:
    """A rigid body as xcheck's integrators need it.

    Attributes
    ----------
    inertia : ndarray (3, 3)
        Inertia tensor about the centre of mass in body components [kg m^2].
    mass : float
        [kg] (not used by the attitude dynamics; kept for reports).
    dipole : ndarray (3,)
        Permanent magnetic dipole in body components [A m^2] (seed 004 eq. 175); zero if none.
    name : str
    """

    inertia: np.ndarray
    mass: float = 1.0
    dipole: np.ndarray = field(default_factory=lambda: np.zeros(3))
    name: str = "body"

    def __post_init__(self):
        object.__setattr__(self, "inertia", validate_inertia(self.inertia))
        d = np.asarray(self.dipole, dtype=float)
        if d.shape != (3,) or not np.all(np.isfinite(d)):
            raise ValueError(f"dipole: expected a finite (3,) vector in A m^2, got {d!r}")
        object.__setattr__(self, "dipole", d)
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ValueError(f"mass: expected a positive number of kg, got {self.mass!r}")

    @property
    def principal_moments(self) -> np.ndarray:
        return principal_axes(self.inertia)[0]
