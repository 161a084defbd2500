"""Torque models as data: what the integrators' compiled kernels evaluate at every stage.

A torque model is a small object holding plain arrays: an integer *kind*, a parameter vector ``P`` and a
table ``T``. :func:`torque_eval` (compiled with numba) evaluates any model from that data without a Python
call per stage, and every model is also a Python callable ``model(t, q, omega) -> (3,)`` [N m] (the same
compiled function) for scipy, MuJoCo's callback and plotting. Any other Python callable with that
signature is accepted by :func:`xcheck.integrators.integrate` too, on a slower, interpreted path.

Magnetic torque (seed 004 eq. 174): ``t' = mu0 (M_p x H)`` in body components, ``H`` the field strength
[A/m] in body components, ``M_p`` the permanent dipole [A m^2], ``mu0 = 4 pi 1e-7`` H/m; ``B = mu0 H`` [T].

Field models, swappable by name in a scenario (:data:`FIELD_MODELS`):

* ``body-table`` (:class:`BodyFieldTable`): H in body components from a CSV time series, linearly
  interpolated; the torque does not depend on attitude (the thesis's set-up).
* ``orbit-dipole`` (:class:`OrbitDipoleField`): a tilted dipole Earth field (IGRF 2010 dipole terms)
  along a circular orbit, fixed in inertial space: ``H_body = R^T H_world``, the torque depends on attitude.
* ``igrf`` (:class:`IGRFField`, optional extra ``igrf``): the full IGRF along the same orbit at an epoch,
  tabulated in world components every 0.5 s and linearly interpolated.
* ``uniform`` (:class:`UniformField`): a constant field in world components.

World frame of the orbit models: an Earth-centred inertial frame (z the rotation axis, x the equinox);
the attitude quaternion maps body to this frame.
"""

from __future__ import annotations

import numpy as np

from ._jit import njit

__all__ = [
    "MU0",
    "FIELD_MODELS",
    "OrbitDipoleField",
    "IGRFField",
    "WorldFieldTable",
    "load_field_table",
    "write_field_table",
    "rax1_synthetic_body_table",
    "write_rax1_body_table",
    "nearest_achievable_torque",
    "SEED004_INITIAL_TORQUE",
    "RAX1_ORBIT",
    "rax1_orbit_phase_residual",
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
FIELD_ORBIT_DIPOLE = 2
FIELD_WORLD_TABLE = 3

#: Seed 004 eq. 177: the thesis's initial torque [N m] (4 printed digits; not exactly perpendicular to M_p).
SEED004_INITIAL_TORQUE = np.array([-0.0012, 0.2166, -0.0038]) * 1e-4

R_EARTH = 6371.2e3  # [m], IGRF reference radius
MU_EARTH = 3.986004418e14  # [m^3/s^2]
OMEGA_EARTH = 7.2921150e-5  # [rad/s], sidereal rotation rate
#: The default orbit of the orbit field models: RAX-1-like (650 km, 72 deg), with the phase (RAAN,
#: argument of latitude, Earth rotation angle at t = 0) fitted so that with seed 004's printed initial
#: attitude and dipole the dipole-field torque at t = 0 is eq. 177's nearest achievable value (measured:
#: 2.0027e-9 N m from the printed torque, of which 2.0016e-9 N m is the printed torque's component along
#: M_p that no dipole torque can have; |B(0)| = 31.9 µT).
RAX1_ORBIT = dict(altitude_km=650.0, inclination_deg=72.0, raan_deg=71.2312, arg_latitude_deg=217.2933,
                  earth_angle_deg=238.5664)
#: IGRF-13 dipole coefficients (g10, g11, h11) for 2010.0 [nT] (RAX-1 flew in 2010-2011).
IGRF2010_DIPOLE_NT = np.array([-29496.57, -1586.42, 4944.26])


@njit(cache=True, error_model="numpy", inline="always")
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


@njit(cache=True, error_model="numpy", inline="always")
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


@njit(cache=True, error_model="numpy", inline="always")
def _orbit_dipole_world(P, t):
    """Field strength H [A/m] in world (inertial) components of a dipole Earth along a circular orbit.

    ``P[4:14] = (a, n, i, raan, u0, theta_g0, omega_e, mx, my, mz)``: orbit radius [m], mean motion
    [rad/s], inclination, right ascension of the ascending node, argument of latitude at t = 0, Earth
    rotation angle at t = 0 [rad], Earth rotation rate [rad/s], dipole moment in Earth-fixed components
    [A m^2]. ``H = (3 (m.r^) r^ - m) / (4 pi |r|^3)``.
    """
    a, n, inc, raan, u0, g0, we = P[4], P[5], P[6], P[7], P[8], P[9], P[10]
    u = u0 + n * t
    cu, su, ci, si, cO, sO = np.cos(u), np.sin(u), np.cos(inc), np.sin(inc), np.cos(raan), np.sin(raan)
    rx = cO * cu - sO * su * ci
    ry = sO * cu + cO * su * ci
    rz = su * si
    g = g0 + we * t  # Earth-fixed -> inertial: rotation by g about z
    cg, sg = np.cos(g), np.sin(g)
    mx = cg * P[11] - sg * P[12]
    my = sg * P[11] + cg * P[12]
    mz = P[13]
    mr = mx * rx + my * ry + mz * rz
    k = 1.0 / (4.0 * np.pi * a * a * a)
    return k * (3.0 * mr * rx - mx), k * (3.0 * mr * ry - my), k * (3.0 * mr * rz - mz)


@njit(cache=True, error_model="numpy", inline="always")
def _field_body(P, T, t, q):
    """Field strength H [A/m] in body components for the field described by ``P[3:]`` and ``T``."""
    kind = int(P[3])
    if kind == FIELD_BODY_TABLE:
        return _interp_rows(T, t)
    if kind == FIELD_UNIFORM:  # H fixed in world components, P[4:7]
        return _world_to_body(q, P[4], P[5], P[6])
    if kind == FIELD_ORBIT_DIPOLE:
        hx, hy, hz = _orbit_dipole_world(P, t)
    else:  # FIELD_WORLD_TABLE
        hx, hy, hz = _interp_rows(T, t)
    return _world_to_body(q, hx, hy, hz)


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


# ------------------------------------------------------------------------------------------------
# field tables (CSV)
# ------------------------------------------------------------------------------------------------
def load_field_table(path) -> np.ndarray:
    """Read a field table: ``#`` comment lines, an optional header line, then rows ``t, Hx, Hy, Hz``
    (comma-separated; t [s] strictly increasing, H [A/m]). Errors name the file and the line."""
    from pathlib import Path

    path = Path(path)
    try:
        lines = path.read_bytes().decode("utf-8-sig").splitlines()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the field table ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text (offset {exc.start}); a field table is a CSV text file") from None
    rows = []
    for number, line in enumerate(lines, start=1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        parts = [p.strip() for p in text.split(",")]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            if not rows and any(c.isalpha() for c in text):
                continue  # a header line
            raise ValueError(f"{path}, line {number}: expected 4 numbers (t [s], Hx, Hy, Hz [A/m]), got {text!r}") \
                from None
        if len(values) != 4:
            raise ValueError(f"{path}, line {number}: expected 4 columns (t [s], Hx, Hy, Hz [A/m]), got {len(values)}")
        if not all(np.isfinite(values)):
            raise ValueError(f"{path}, line {number}: non-finite value in {text!r}")
        rows.append(values)
    table = np.array(rows, dtype=float).reshape(-1, 4)
    if len(table) < 2:
        raise ValueError(f"{path}: a field table needs at least 2 rows, found {len(table)}")
    bad = np.nonzero(np.diff(table[:, 0]) <= 0)[0]
    if len(bad):
        raise ValueError(f"{path}: the time column must be strictly increasing (row {bad[0] + 2} of the data)")
    return table


def write_field_table(path, table, header_lines=()) -> None:
    """Write a field table (see :func:`load_field_table`) with ``#`` header lines, 12 significant digits."""
    with open(path, "w") as f:
        for line in header_lines:
            f.write(f"# {line}\n")
        f.write("t_s,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m\n")
        for row in np.asarray(table, dtype=float):
            f.write(",".join(f"{v:.12g}" for v in row) + "\n")


# ------------------------------------------------------------------------------------------------
# the RAX-1 set-up of seed 004 §3.2
# ------------------------------------------------------------------------------------------------
def nearest_achievable_torque(dipole, torque) -> tuple[np.ndarray, float]:
    """The torque ``mu0 M x H`` (perpendicular to M) nearest to ``torque``, and the distance [N m]."""
    m = np.asarray(dipole, dtype=float)
    mhat = m / np.linalg.norm(m)
    along = float(np.dot(torque, mhat))
    return np.asarray(torque, float) - along * mhat, abs(along)


def rax1_synthetic_body_table(dipole=(0.14, 0.02, 1.09), *, duration: float = 500.0, spacing: float = 0.5,
                              B0_tesla: float = 35e-6) -> np.ndarray:
    """A smooth synthetic body-frame field for RAX-1 (the flight data of seed 004 Fig. 7 is not available).

    At t = 0 it gives the torque nearest to the thesis's eq. 177 that a dipole torque can be (the
    printed one has a 2.0e-9 N m component along M_p, a 4-digit rounding); the field's component along
    M_p, free in that fit, is chosen positive (the permanent magnet aligns with the field) so that
    |B(0)| = ``B0_tesla`` (35 µT, a LEO value). Then the perpendicular part turns about M_p once every
    250 s (the body's slow spin) with its size varying by ±15 % (400 s period) and the parallel part by
    ±10 % (600 s period): |B| stays within 32-39 µT. Rows every ``spacing`` s, so that the knots fall on
    step boundaries of every step 1/2, 1/4, ... s: the linear interpolation is then smooth within each
    step and RK4 keeps its order 4.
    """
    m = np.asarray(dipole, dtype=float)
    mhat = m / np.linalg.norm(m)
    tau, _ = nearest_achievable_torque(m, SEED004_INITIAL_TORQUE)
    H_perp0 = np.cross(tau, m) / (MU0 * np.dot(m, m))  # mu0 m x H_perp0 = tau
    H_total = B0_tesla / MU0
    H_par0 = np.sqrt(H_total**2 - np.dot(H_perp0, H_perp0))
    t = np.arange(0.0, duration + spacing / 2, spacing)
    phi = 2 * np.pi * t / 250.0
    # Rodrigues rotation of H_perp0 (perpendicular to mhat) about mhat by phi
    rotated = (np.cos(phi)[:, None] * H_perp0 + np.sin(phi)[:, None] * np.cross(mhat, H_perp0))
    H = (1 + 0.15 * np.sin(2 * np.pi * t / 400.0))[:, None] * rotated + \
        (H_par0 * (1 + 0.10 * np.sin(2 * np.pi * t / 600.0)))[:, None] * mhat
    return np.column_stack([t, H])


RAX1_TABLE_HEADER = (
    "RAX-1 body-frame magnetic field strength H [A/m] for seed 004 §3 (xcheck).",
    "SYNTHETIC: the RAX-1 flight magnetometer data of the thesis (Fig. 7) is not available to us.",
    "Made by xcheck.fields.write_rax1_body_table(): at t = 0 the torque mu0 M_p x H with",
    "M_p = [0.14, 0.02, 1.09] A m^2 is the achievable torque nearest to the thesis eq. 177",
    "[-0.0012, 0.2166, -0.0038]e-4 N m (2.0e-9 N m away: the printed value has that component along M_p);",
    "the component of H along M_p is chosen so that |B(0)| = 35 uT. Then H turns about M_p every 250 s and",
    "varies slowly: |B| stays within 32-39 uT, a LEO field. Rows every 0.5 s over 0-500 s (knots on the",
    "steps of every dt = 1/2^k s, so linear interpolation keeps RK4 at order 4). Columns: t [s], Hx, Hy, Hz [A/m].",
)


def write_rax1_body_table(path) -> None:
    """(Re)write the bundled ``models/rax1_field_body.csv``."""
    write_field_table(path, rax1_synthetic_body_table(), RAX1_TABLE_HEADER)


# ------------------------------------------------------------------------------------------------
# orbit field models (inertial)
# ------------------------------------------------------------------------------------------------
def _circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg):
    a = R_EARTH + 1e3 * float(altitude_km)
    if not (np.isfinite(a) and float(altitude_km) > 0):
        raise ValueError(f"altitude_km: expected a positive altitude in km, got {altitude_km!r}")
    for name, v in (("inclination_deg", inclination_deg), ("raan_deg", raan_deg),
                    ("arg_latitude_deg", arg_latitude_deg)):
        if not np.isfinite(float(v)):
            raise ValueError(f"{name}: expected a finite angle in degrees, got {v!r}")
    return a, np.sqrt(MU_EARTH / a**3)


def orbit_position(t, altitude_km, inclination_deg, raan_deg, arg_latitude_deg) -> np.ndarray:
    """Inertial position [m] on a circular orbit at times ``t`` (n,) -> (n, 3)."""
    a, n = _circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
    u = np.radians(arg_latitude_deg) + n * np.asarray(t, dtype=float)
    i, O = np.radians(inclination_deg), np.radians(raan_deg)
    return a * np.stack([np.cos(O) * np.cos(u) - np.sin(O) * np.sin(u) * np.cos(i),
                         np.sin(O) * np.cos(u) + np.cos(O) * np.sin(u) * np.cos(i),
                         np.sin(u) * np.sin(i)], axis=-1)


class OrbitDipoleField:
    """A tilted dipole Earth (IGRF 2010 dipole: 29.95 µT at the equator, pole tilted 9.97°) seen along a
    circular orbit, in inertial components [A/m]; the Earth turns under the orbit.

    The defaults are RAX-1-like (650 km, 72°), with the orbit phase (RAAN, argument of latitude, Earth
    rotation angle at t = 0) chosen so that, with seed 004's printed initial attitude (eq. 178) and
    M_p, the torque at t = 0 is close to the thesis's eq. 177 (see :func:`rax1_orbit_phase_residual`).
    """

    kind = FIELD_ORBIT_DIPOLE
    attitude_dependent = True
    T = _EMPTY_TABLE

    def __init__(self, *, altitude_km: float = RAX1_ORBIT["altitude_km"],
                 inclination_deg: float = RAX1_ORBIT["inclination_deg"], raan_deg: float = RAX1_ORBIT["raan_deg"],
                 arg_latitude_deg: float = RAX1_ORBIT["arg_latitude_deg"],
                 earth_angle_deg: float = RAX1_ORBIT["earth_angle_deg"], dipole_nT=IGRF2010_DIPOLE_NT):
        self.altitude_km = float(altitude_km)
        self.inclination_deg = float(inclination_deg)
        self.raan_deg = float(raan_deg)
        self.arg_latitude_deg = float(arg_latitude_deg)
        self.earth_angle_deg = float(earth_angle_deg)
        self.a, self.n = _circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
        if not np.isfinite(self.earth_angle_deg):
            raise ValueError(f"earth_angle_deg: expected a finite angle, got {earth_angle_deg!r}")
        g10, g11, h11 = np.asarray(dipole_nT, dtype=float) * 1e-9  # [T]
        self.moment = 4 * np.pi * R_EARTH**3 / MU0 * np.array([g11, h11, g10])  # Earth-fixed [A m^2]

    def params(self) -> np.ndarray:
        return np.concatenate([[float(self.kind), self.a, self.n, np.radians(self.inclination_deg),
                                np.radians(self.raan_deg), np.radians(self.arg_latitude_deg),
                                np.radians(self.earth_angle_deg), OMEGA_EARTH], self.moment])

    def check_span(self, t_end: float) -> None:
        pass

    def H_world(self, t) -> np.ndarray:
        """Field strength [A/m] in inertial components at times ``t`` (...,) -> (..., 3)."""
        P = np.concatenate([[0.0, 0.0, 0.0], self.params()])
        t = np.asarray(t, dtype=float)
        out = np.array([_orbit_dipole_world(P, float(tt)) for tt in t.ravel()])
        return out.reshape(t.shape + (3,))

    def describe(self) -> str:
        return (f"dipole Earth field along a circular orbit ({self.altitude_km:g} km, {self.inclination_deg:g}°, "
                f"RAAN {self.raan_deg:g}°, u0 {self.arg_latitude_deg:g}°)")


class WorldFieldTable(BodyFieldTable):
    """A field strength time series in world (inertial) components, linearly interpolated: the torque
    depends on attitude. (Knots every 0.5 s fall on the steps' boundaries: RK4 keeps its order.)"""

    kind = FIELD_WORLD_TABLE
    attitude_dependent = True

    def describe(self) -> str:
        return f"world-frame field table {self.source} ({self.T.shape[0]} rows)"


class IGRFField(WorldFieldTable):
    """The IGRF model (``ppigrf``, optional extra ``igrf``) along the circular orbit of
    :class:`OrbitDipoleField` at ``epoch``, tabulated in inertial components every ``spacing`` s."""

    def __init__(self, *, duration: float, epoch: str = "2010-11-20T00:00:00", spacing: float = 0.5,
                 altitude_km: float = RAX1_ORBIT["altitude_km"], inclination_deg: float = RAX1_ORBIT["inclination_deg"],
                 raan_deg: float = RAX1_ORBIT["raan_deg"], arg_latitude_deg: float = RAX1_ORBIT["arg_latitude_deg"],
                 earth_angle_deg: float = RAX1_ORBIT["earth_angle_deg"]):
        try:
            import ppigrf
        except ImportError:
            raise ValueError("field 'igrf' needs the optional extra: pip install 'xcheck[igrf]'") from None
        from datetime import datetime

        try:
            date = datetime.fromisoformat(str(epoch))
        except ValueError:
            raise ValueError(f"epoch: expected an ISO date like 2010-11-20T00:00:00, got {epoch!r}") from None
        t = np.arange(0.0, float(duration) + spacing, spacing)
        r_eci = orbit_position(t, altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
        g = np.radians(earth_angle_deg) + OMEGA_EARTH * t
        cg, sg = np.cos(g), np.sin(g)
        x, y, z = cg * r_eci[:, 0] + sg * r_eci[:, 1], -sg * r_eci[:, 0] + cg * r_eci[:, 1], r_eci[:, 2]  # ECEF
        r = np.linalg.norm(r_eci, axis=1)
        theta = np.arccos(z / r)
        phi = np.arctan2(y, x)
        Br, Bth, Bph = ppigrf.igrf_gc(r / 1e3, np.degrees(theta), np.degrees(phi), date)  # [nT]
        Br, Bth, Bph = (np.asarray(b, dtype=float).reshape(-1) * 1e-9 for b in (Br, Bth, Bph))
        st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
        Bx = Br * st * cp + Bth * ct * cp - Bph * sp
        By = Br * st * sp + Bth * ct * sp + Bph * cp
        Bz = Br * ct - Bth * st
        B_eci = np.stack([cg * Bx - sg * By, sg * Bx + cg * By, Bz], axis=1)
        super().__init__(np.column_stack([t, B_eci / MU0]), source=f"IGRF at {epoch}")


def rax1_orbit_phase_residual(field=None, dipole=(0.14, 0.02, 1.09), q0=(-0.4583, -0.6558, 0.5997, 0.0182)):
    """The torque at t = 0 of the orbit field with seed 004's printed attitude and dipole, its distance to
    eq. 177 [N m], and |B(0)| [T]."""
    from . import rotations as rot

    field = field or OrbitDipoleField()
    H_body = rot.quat_rotate(rot.quat_conj(rot.quat_normalize(q0)), field.H_world(np.array([0.0]))[0])
    torque = magnetic_torque(dipole, H_body)
    return torque, float(np.linalg.norm(torque - SEED004_INITIAL_TORQUE)), float(MU0 * np.linalg.norm(H_body))


#: Field models by the name a scenario gives them.
FIELD_MODELS = {"body-table": BodyFieldTable, "orbit-dipole": OrbitDipoleField, "igrf": IGRFField,
                "uniform": UniformField, "world-table": WorldFieldTable}
