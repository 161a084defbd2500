"""Torque models (what the integrators evaluate) and the field models a magnetic torque sees.

A *field model* is one declaration: a subclass of :class:`Field` that names itself (``name``, the scenario's
``field = "..."``), its scenario keys (``keys``), its parameter slots (``slots``, read by the compiled
evaluator in that order), the components it is given in (``frame``: ``"body"``, or ``"world"`` and then the
torque depends on attitude), which compiled evaluator computes it (``evaluator``), and how a scenario's values
build it (``from_keys``). :data:`xcheck.fields.FIELDS` registers it by name; the scenario reader, the torque
builder and their error messages read that registry only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from . import kernel

_EMPTY_TABLE = np.zeros((0, 4))


def _vector3(name, value, unit):
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: expected a finite (3,) vector in {unit}, got {value!r}")
    return v


# ------------------------------------------------------------------------------------------------
# torque models
# ------------------------------------------------------------------------------------------------
class TorqueModel:
    """A torque as data: ``kind`` (:mod:`.kernel`), ``P`` (1-D float array, by the kernel's named slots) and
    ``T`` (2-D float array). Every model is also a Python callable ``model(t, q, omega) -> (3,)`` [N m], the
    same compiled function the integrators call."""

    kind: int = kernel.FREE
    P: np.ndarray = np.zeros(3)
    T: np.ndarray = _EMPTY_TABLE
    attitude_dependent: bool = False
    #: an internal torque (a gyrostat's wheels): the world angular momentum ``R (I w + h(t))`` is conserved, every
    #: component (:meth:`internal_momentum`'s ``h``)
    conserves_momentum: bool = False

    def internal_momentum(self, t) -> np.ndarray | None:
        """``h(t)`` [kg m^2/s], body components, (n, 3) at times ``t`` (n,): the momentum that the body carries
        beside ``I w`` (a gyrostat's wheels), so that its angular momentum is ``I w + h``; None: none."""
        return None

    def kernel_data(self) -> tuple[int, np.ndarray, np.ndarray]:
        return self.kind, self.P, self.T

    def __call__(self, t, q, omega) -> np.ndarray:
        out = np.empty(3)
        kernel.torque_eval(self.kind, self.P, self.T, float(t), np.ascontiguousarray(q, dtype=float),
                           np.ascontiguousarray(omega, dtype=float), out)
        return out

    def many(self, t, q, omega) -> np.ndarray:
        """The torque at every row: ``t`` (n,), ``q`` (n, 4), ``omega`` (n, 3) -> (n, 3) [N m], compiled (the same
        numbers as ``model(t[i], q[i], omega[i])``)."""
        t = np.ascontiguousarray(t, dtype=float)
        q = np.ascontiguousarray(np.broadcast_to(q, t.shape + (4,)), dtype=float)
        omega = np.ascontiguousarray(np.broadcast_to(omega, t.shape + (3,)), dtype=float)
        out = np.empty(t.shape + (3,))
        kernel.torque_many(self.kind, self.P, self.T, t, q, omega, out)
        return out

    def check_span(self, t_end: float) -> None:
        """Raise ValueError if the model is not defined on ``[0, t_end]``."""

    def breakpoints(self, t_end: float) -> np.ndarray:
        """The times in ``(0, t_end)`` where the torque's time derivative jumps (a linearly interpolated table's
        rows): an adaptive reference restarts there (:func:`xcheck.reference.dop853_solution`)."""
        return np.empty(0)

    def potential(self, q) -> np.ndarray | None:
        """The potential energy [J] at attitudes ``q`` (..., 4) whose torque this is, when it is conservative
        (then the kinetic energy plus it is conserved); None otherwise."""
        return None

    def momentum_axis(self) -> np.ndarray | None:
        """A world direction (unit) about which the torque never has a component, so that the angular momentum
        along it is conserved; None when there is none."""
        return None

    def fixed_form(self):
        """``(c, F)`` when the torque is ``c x (R^T F)`` with both fixed (see :class:`MagneticTorque`); None."""
        return None

    def describe(self) -> str:
        return type(self).__name__


class ConstantTorque(TorqueModel):
    """A constant torque in body components [N m]."""

    kind = kernel.CONSTANT

    def __init__(self, torque_body):
        self.P = _vector3("torque_body", torque_body, "N m").copy()

    def describe(self) -> str:
        return f"constant body torque {self.P.tolist()} N m"


class MagneticTorque(TorqueModel):
    """Seed 004 eq. 174: ``t' = mu0 (M_p x H_body)`` for a permanent dipole in a field model."""

    kind = kernel.MAGNETIC

    def __init__(self, dipole, field: Field):
        self.dipole = _vector3("dipole", dipole, "A m^2")
        self.field = field
        self.P = np.concatenate([self.dipole, field.params()])
        self.T = np.ascontiguousarray(field.T) if field.T.size else _EMPTY_TABLE
        self.attitude_dependent = field.attitude_dependent

    def check_span(self, t_end: float) -> None:
        self.field.check_span(t_end)

    def breakpoints(self, t_end: float) -> np.ndarray:
        return self.field.breakpoints(t_end)

    def _fixed_world_field(self) -> np.ndarray | None:
        """H [A/m] of a field fixed in the world (uniform, not changing), else None."""
        if self.field.frame != "world" or self.field.time_dependent:
            return None
        return np.asarray(self.field.strength(0.0), dtype=float)

    def potential(self, q) -> np.ndarray | None:
        """A dipole in a field fixed in the world: ``-mu0 (R M_p) . H`` (a top's ``-m g . (R c)``)."""
        from ..rotations import quat_rotate

        H = self._fixed_world_field()
        if H is None:
            return None
        return -kernel.MU0 * (quat_rotate(q, self.dipole) @ H)

    def fixed_form(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(c, F)`` when the torque is ``c x (R^T F)`` with both fixed (a dipole in a field fixed in the world:
        ``c = M_p``, ``F = mu0 H``; a top's gravity: ``c`` its centre of mass from the pivot, ``F = m g``), the form
        of Lagrange's top (:func:`xcheck.reference.lagrange_top`); None otherwise."""
        H = self._fixed_world_field()
        return None if H is None else (self.dipole.copy(), kernel.MU0 * H)

    def momentum_axis(self) -> np.ndarray | None:
        """A dipole in a field fixed in the world: the field's direction (the torque ``R (M_p x R^T H)`` is
        perpendicular to ``H``); a top's: the vertical."""
        H = self._fixed_world_field()
        if H is None or not np.any(H):
            return None
        return H / np.linalg.norm(H)

    def describe(self) -> str:
        return f"magnetic dipole {self.dipole.tolist()} A m^2 in {self.field.describe()}"


class GravityTorque(MagneticTorque):
    """Gravity's torque about a pivot (issue 27, the heavy top): ``tau = c x (m R^T g)`` in body components, ``c``
    [m] the centre of mass from the pivot (body frame), ``m`` [kg], ``g`` [m/s^2] (world frame). It has the form of
    a dipole in a field fixed in the world, ``tau = mu0 (M_p x H_body)`` with ``M_p = c`` and ``mu0 H = m g``, so
    it is evaluated by that compiled kernel, at every stage like the magnetic torque (attitude dependent). MuJoCo's
    own gravity gives the same torque on a ball joint (``tests/test_mujoco_ball_joint.py``)."""

    def __init__(self, centre, mass: float, gravity):
        self.centre = _vector3("centre", centre, "m")
        if not (np.isfinite(mass) and mass > 0):
            raise ValueError(f"mass: expected a positive finite mass in kg, got {mass!r}")
        self.mass = float(mass)
        self.gravity = _vector3("gravity", gravity, "m/s^2")
        super().__init__(self.centre, UniformField(self.mass * self.gravity / kernel.MU0))

    def describe(self) -> str:
        return (f"gravity {self.gravity.tolist()} m/s^2 on {self.mass:g} kg, centre of mass {self.centre.tolist()} m "
                "from the pivot")


class SumTorque(TorqueModel):
    """Torques that compose (issues 27, 28): the sum of its terms — constant torques and dipoles in fields (a top's
    gravity is one) — evaluated term by term at every stage in compiled code (:data:`kernel.SUM`), in the order given.
    At most one term may carry a table (they share ``T``). What it conserves is what every term conserves: a
    potential when each has one (their sum), a momentum axis when each has the same."""

    kind = kernel.SUM

    def __init__(self, terms):
        flat = []
        for term in terms:
            flat += term.terms if isinstance(term, SumTorque) else [term]
        if len(flat) < 2:
            raise ValueError(f"terms: a sum needs two torques or more, got {len(flat)}")
        for term in flat:
            if term.kind not in (kernel.CONSTANT, kernel.MAGNETIC, kernel.GRAVITY_GRADIENT, kernel.WHEELS):
                raise ValueError(f"terms: a sum adds constant, magnetic, gravity-gradient and wheels' torques, got "
                                 f"{type(term).__name__}")
        tables = [term for term in flat if term.T.size]
        if len(tables) > 1:
            raise ValueError(f"terms: {len(tables)} of them read a table ({', '.join(t.describe() for t in tables)}); "
                             "a sum takes at most one")
        if sum(term.kind == kernel.WHEELS for term in flat) > 1:
            raise ValueError("terms: one body has one set of wheels")
        self.terms = flat
        self.attitude_dependent = any(term.attitude_dependent for term in flat)
        self.conserves_momentum = all(term.conserves_momentum for term in flat)
        header, body, start = [float(len(flat)), float(self.attitude_dependent)], [], 2 + 3 * len(flat)
        for term in flat:
            header += [float(term.kind), float(start), float(len(term.P))]
            body.append(np.asarray(term.P, dtype=float))
            start += len(term.P)
        self.P = np.concatenate([np.array(header), *body])
        self.T = np.ascontiguousarray(tables[0].T) if tables else _EMPTY_TABLE

    def check_span(self, t_end: float) -> None:
        for term in self.terms:
            term.check_span(t_end)

    def breakpoints(self, t_end: float) -> np.ndarray:
        return np.unique(np.concatenate([term.breakpoints(t_end) for term in self.terms]))

    def potential(self, q):
        parts = [term.potential(q) for term in self.terms]
        return None if any(p is None for p in parts) else sum(parts)

    def internal_momentum(self, t):
        parts = [h for h in (term.internal_momentum(t) for term in self.terms) if h is not None]
        return sum(parts) if parts else None

    def momentum_axis(self):
        """The axis every external term conserves the momentum about (the wheels' conserve all of it)."""
        axes = [term.momentum_axis() for term in self.terms if not term.conserves_momentum]
        if not axes or any(a is None for a in axes) or any(abs(abs(a @ axes[0]) - 1.0) > 1e-12 for a in axes):
            return None
        return axes[0]

    def describe(self) -> str:
        return " + ".join(term.describe() for term in self.terms)


class WheelsTorque(TorqueModel):
    """A gyrostat's wheels (issue 28) as a torque on its body: ``-w x h(t) - h'(t)`` [N m], with ``I`` the body's
    inertia less each wheel's axial moment about its axis (``J_s a a^T``) and ``h`` the wheels' absolute axial
    momentum, ``sum_i p_i(t) a_i``. Then ``I w' + w x (I w + h) = tau - h'`` is the gyrostat form of Euler's
    equation, every method's rigid body with one torque more. ``p_i = J_s (a_i . w + Omega_i)``, ``Omega_i`` the
    wheel's speed relative to the body: constant for a free wheel (no motor torque about a frictionless axle),
    changed only by its motor's torque, ``p_i' = u_i(t)``. So ``h`` is a function of time alone, never part of the
    state: ``h0`` plus each motor command's integral, a pulse ``u sin^2(pi (t - t0) / (t1 - t0))`` on ``[t0, t1]``
    (:func:`.kernel.pulse`). A wheel's speed is ``p_i(t) / J_s - a_i . w`` (:meth:`wheel_speeds`)."""

    kind = kernel.WHEELS
    conserves_momentum = True

    def __init__(self, h0, commands=(), *, wheels=()):
        self.h0 = _vector3("h0", h0, "kg m^2/s")
        rows = []
        for k, (axis, peak, t0, t1) in enumerate(commands):
            a = _vector3(f"commands[{k}].axis", axis, "(unit)")
            if abs(np.linalg.norm(a) - 1.0) > 1e-9:
                raise ValueError(f"commands[{k}].axis: expected a unit vector, got {a.tolist()}")
            if not (np.isfinite(peak) and np.isfinite(t0) and np.isfinite(t1) and 0 <= t0 < t1):
                raise ValueError(f"commands[{k}]: expected a finite peak torque [N m] and 0 <= t0 < t1 [s], got "
                                 f"{peak!r}, {t0!r}, {t1!r}")
            rows.append([*a, float(peak), float(t0), float(t1)])
        self.commands = np.array(rows, dtype=float).reshape(-1, 6)
        self.wheels = tuple(wheels)  # per wheel: axis (3,), axial moment J_s [kg m^2], p0, its command's index or None
        self.P = np.concatenate([self.h0, [float(len(rows))], self.commands.ravel()])

    def _pulses(self, t):
        """Each command's integral and value at times ``t`` (n,): two (n, k) arrays (:func:`.kernel.pulse`)."""
        t = np.asarray(t, dtype=float)[:, None]
        u, t0, t1 = self.commands[:, 3], self.commands[:, 4], self.commands[:, 5]
        s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        sn = np.sin(np.pi * s)
        return u * (t1 - t0) * (0.5 * s - np.sin(2.0 * np.pi * s) / (4.0 * np.pi)), u * sn * sn

    def internal_momentum(self, t) -> np.ndarray:
        integral, _ = self._pulses(t)
        return self.h0 + integral @ self.commands[:, :3]

    def wheel_speeds(self, t, omega) -> np.ndarray:
        """Each wheel's speed relative to the body [rad/s], (n, k), at times ``t`` (n,) and body rates ``omega``
        (n, 3): ``p_i(t) / J_s - a_i . w``, its motor's pulses added to ``p_i`` (a command per wheel, in order)."""
        omega = np.asarray(omega, dtype=float)
        out = np.empty((len(omega), len(self.wheels)))
        integral, _ = self._pulses(t)
        for i, (axis, moment, p0, command) in enumerate(self.wheels):
            p = p0 + (integral[:, command] if command is not None else 0.0)
            out[:, i] = p / moment - omega @ np.asarray(axis, dtype=float)
        return out

    def breakpoints(self, t_end: float) -> np.ndarray:
        t = self.commands[:, 4:6].ravel()
        return np.unique(t[(t > 0) & (t < t_end)])

    def potential(self, q):
        """Free wheels: the body's ``1/2 w.I w`` is conserved (the wheels' own energy, ``p^2 / 2 J_s``, is
        constant), so the potential is zero; a motor works on it: None."""
        return np.zeros(np.shape(q)[:-1]) if not len(self.commands) else None

    def describe(self) -> str:
        words = f"{len(self.wheels)} wheel(s), momentum {np.round(self.h0, 12).tolist()} kg m^2/s"
        if len(self.commands):
            words += "; motor pulses " + ", ".join(f"{c[3]:g} N m over {c[4]:g}-{c[5]:g} s" for c in self.commands)
        return words


def magnetic_torque(dipole, H_body):
    """``mu0 (M_p x H)`` (seed 004 eq. 174) for stacks ``(..., 3)``: dipole [A m^2], H [A/m] -> [N m]."""
    return kernel.MU0 * np.cross(np.asarray(dipole, float), np.asarray(H_body, float))


# ------------------------------------------------------------------------------------------------
# field models
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Key:
    """A scenario key of a field model: ``kind`` is ``"number"``, ``"vector3"``, ``"string"`` or ``"path"`` (a
    file, relative to the scenario)."""

    kind: str
    required: bool = False
    help: str = ""


class Field:
    """A magnetic field model (see the module docstring for the declaration it makes)."""

    name: ClassVar[str]
    keys: ClassVar[dict[str, Key]] = {}
    slots: ClassVar[tuple[str, ...]] = ()
    frame: ClassVar[str] = "world"
    #: Whether the field changes with time (False: a field fixed in its frame, which an engine writes once).
    time_dependent: ClassVar[bool] = True
    evaluator: ClassVar[int]
    T: np.ndarray = _EMPTY_TABLE

    @property
    def attitude_dependent(self) -> bool:
        """Whether the torque depends on attitude: the field is given in world components."""
        return self.frame == "world"

    @classmethod
    def from_keys(cls, values: dict, *, duration: float) -> Field:
        """The model from a scenario's values of :attr:`keys` (paths as strings), for a run of ``duration``."""
        return cls(**values)

    def slot_values(self) -> dict[str, float]:
        """The values of :attr:`slots` (compiled evaluators read them in that order)."""
        return {}

    def params(self) -> np.ndarray:
        """This field's part of a torque model's ``P``: evaluator, frame, then the slots in order."""
        values = self.slot_values()
        if list(values) != list(self.slots):
            raise AssertionError(f"{type(self).__name__}: slot_values() gives {list(values)}, slots declare "
                                 f"{list(self.slots)}")
        frame = {"body": kernel.BODY, "world": kernel.WORLD}[self.frame]
        return np.array([float(self.evaluator), float(frame), *values.values()], dtype=float)

    def check_span(self, t_end: float) -> None:
        """Raise ValueError if the field is not defined on ``[0, t_end]``."""

    def breakpoints(self, t_end: float) -> np.ndarray:
        """A table's rows in ``(0, t_end)``: the field is linear between them, its derivative jumps at them."""
        t = self.T[:, 0] if self.T.size else np.empty(0)
        return t[(t > 0) & (t < t_end)]

    def strength(self, t) -> np.ndarray:
        """Field strength [A/m] in the components of :attr:`frame` at times ``t`` (...,) -> (..., 3)."""
        raise NotImplementedError(f"{type(self).__name__} does not evaluate its field outside the kernel")

    def describe(self) -> str:
        return self.name


class BodyFieldTable(Field):
    """A field strength time series in body components (CSV columns t [s], Hx, Hy, Hz [A/m]), linearly
    interpolated: the torque does not depend on attitude (seed 004 §3.2, the thesis's set-up)."""

    name = "body-table"
    keys = {"table": Key("path", required=True, help="CSV: t [s], Hx, Hy, Hz [A/m]")}
    frame = "body"
    evaluator = kernel.TABLE

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

    @classmethod
    def from_keys(cls, values, *, duration):
        from .tables import load_field_table

        return cls(load_field_table(values["table"]), source=values["table"])

    def check_span(self, t_end: float) -> None:
        t0, t1 = self.T[0, 0], self.T[-1, 0]
        if t0 > 0 or t1 < t_end:
            raise ValueError(f"{self.source}: the field table covers {t0:g} to {t1:g} s; the run needs 0 to "
                             f"{t_end:g} s (times outside a table are an error, not an extrapolation)")

    def strength(self, t) -> np.ndarray:
        """Field strength [A/m] in the table's components at times ``t`` (...,) -> (..., 3)."""
        t = np.asarray(t, dtype=float)
        return np.stack([np.interp(t, self.T[:, 0], self.T[:, k]) for k in (1, 2, 3)], axis=-1)

    H_body = strength

    def describe(self) -> str:
        return f"body-frame field table {self.source} ({self.T.shape[0]} rows, {self.T[0, 0]:g}-{self.T[-1, 0]:g} s)"


class WorldFieldTable(BodyFieldTable):
    """A field strength time series in world (inertial) components, linearly interpolated: the torque
    depends on attitude. (Knots every 0.5 s fall on the steps' boundaries: RK4 keeps its order.)"""

    name = "world-table"
    frame = "world"

    def describe(self) -> str:
        return f"world-frame field table {self.source} ({self.T.shape[0]} rows)"


class UniformField(Field):
    """A field fixed in inertial space (world components, [A/m]): the torque depends on attitude."""

    name = "uniform"
    keys = {"H_world": Key("vector3", required=True, help="[A/m], world components")}
    slots = ("Hx", "Hy", "Hz")
    frame = "world"
    time_dependent = False
    evaluator = kernel.CONSTANT_FIELD

    def __init__(self, H_world):
        self.H_world = _vector3("H_world", H_world, "A/m")

    def slot_values(self):
        return dict(zip(self.slots, self.H_world.tolist()))

    def strength(self, t) -> np.ndarray:
        return np.broadcast_to(self.H_world, np.shape(t) + (3,)).copy()

    def describe(self) -> str:
        return f"uniform inertial field {self.H_world.tolist()} A/m"
