"""The Earth's field along a circular orbit: orbit maths and the tilted-dipole field model.

World frame of the orbit models: an Earth-centred inertial frame (z the rotation axis, x the equinox); the
attitude quaternion maps body to this frame.
"""

from __future__ import annotations

import numpy as np

from ..body import validate_inertia
from . import kernel
from .models import Field, Key, TorqueModel

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
#: The scenario keys of the orbit field models (each optional: the default is :data:`RAX1_ORBIT`).
ORBIT_KEYS = {
    "altitude_km": Key("number", help="circular orbit altitude [km]"),
    "inclination_deg": Key("number", help="[deg]"),
    "raan_deg": Key("number", help="right ascension of the ascending node [deg]"),
    "arg_latitude_deg": Key("number", help="argument of latitude at t = 0 [deg]"),
    "earth_angle_deg": Key("number", help="Earth rotation angle at t = 0 [deg]"),
}


#: The highest circular orbit [km] of the orbit models: the Earth's Hill sphere (1.5 million km), past which the Sun,
#: not the Earth, holds a body (1e300 overflowed the mean motion).
MAX_ALTITUDE_KM = 1.5e6


def circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg) -> tuple[float, float]:
    """Radius [m] and mean motion [rad/s] of a circular orbit; ValueError naming a bad argument."""
    if not 0 < float(altitude_km) <= MAX_ALTITUDE_KM:
        raise ValueError(f"altitude_km: expected a positive altitude of at most {MAX_ALTITUDE_KM:.2g} km (the Earth's "
                         f"Hill sphere: beyond, no orbit about the Earth), got {altitude_km!r}")
    a = R_EARTH + 1e3 * float(altitude_km)
    for name, v in (("inclination_deg", inclination_deg), ("raan_deg", raan_deg),
                    ("arg_latitude_deg", arg_latitude_deg)):
        if not np.isfinite(float(v)):
            raise ValueError(f"{name}: expected a finite angle in degrees, got {v!r}")
    return a, np.sqrt(MU_EARTH / a**3)


def orbit_position(t, altitude_km, inclination_deg, raan_deg, arg_latitude_deg) -> np.ndarray:
    """Inertial position [m] on a circular orbit at times ``t`` (n,) -> (n, 3)."""
    a, n = circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
    u = np.radians(arg_latitude_deg) + n * np.asarray(t, dtype=float)
    i, O = np.radians(inclination_deg), np.radians(raan_deg)
    return a * np.stack([np.cos(O) * np.cos(u) - np.sin(O) * np.sin(u) * np.cos(i),
                         np.sin(O) * np.cos(u) + np.cos(O) * np.sin(u) * np.cos(i),
                         np.sin(u) * np.sin(i)], axis=-1)


class OrbitDipoleField(Field):
    """A tilted dipole Earth (IGRF 2010 dipole: 29.95 µT at the equator, pole tilted 9.97°) seen along a
    circular orbit, in inertial components [A/m]; the Earth turns under the orbit.

    The defaults are RAX-1-like (650 km, 72°), with the orbit phase (RAAN, argument of latitude, Earth
    rotation angle at t = 0) chosen so that, with seed 004's printed initial attitude (eq. 178) and
    M_p, the torque at t = 0 is close to the thesis's eq. 177 (see :func:`~xcheck.fields.rax1_orbit_phase_residual`).
    """

    name = "orbit-dipole"
    keys = ORBIT_KEYS
    slots = ("radius_m", "mean_motion", "inclination", "raan", "arg_latitude0", "earth_angle0", "earth_rate",
             "moment_x", "moment_y", "moment_z")  # angles [rad], rates [rad/s], moment Earth-fixed [A m^2]
    frame = "world"
    evaluator = kernel.ORBIT_DIPOLE

    def __init__(self, *, altitude_km: float = RAX1_ORBIT["altitude_km"],
                 inclination_deg: float = RAX1_ORBIT["inclination_deg"], raan_deg: float = RAX1_ORBIT["raan_deg"],
                 arg_latitude_deg: float = RAX1_ORBIT["arg_latitude_deg"],
                 earth_angle_deg: float = RAX1_ORBIT["earth_angle_deg"], dipole_nT=IGRF2010_DIPOLE_NT):
        self.altitude_km = float(altitude_km)
        self.inclination_deg = float(inclination_deg)
        self.raan_deg = float(raan_deg)
        self.arg_latitude_deg = float(arg_latitude_deg)
        self.earth_angle_deg = float(earth_angle_deg)
        self.a, self.n = circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
        if not np.isfinite(self.earth_angle_deg):
            raise ValueError(f"earth_angle_deg: expected a finite angle, got {earth_angle_deg!r}")
        g10, g11, h11 = np.asarray(dipole_nT, dtype=float) * 1e-9  # [T]
        self.moment = 4 * np.pi * R_EARTH**3 / kernel.MU0 * np.array([g11, h11, g10])  # Earth-fixed [A m^2]

    def slot_values(self):
        return dict(zip(self.slots, [self.a, self.n, np.radians(self.inclination_deg), np.radians(self.raan_deg),
                                     np.radians(self.arg_latitude_deg), np.radians(self.earth_angle_deg),
                                     OMEGA_EARTH, *self.moment]))

    def H_world(self, t) -> np.ndarray:
        """Field strength [A/m] in inertial components at times ``t`` (...,) -> (..., 3)."""
        p = np.array(list(self.slot_values().values()), dtype=float)
        t = np.asarray(t, dtype=float)
        out = np.array([kernel.orbit_dipole_world(p, float(tt)) for tt in t.ravel()])
        return out.reshape(t.shape + (3,))

    strength = H_world

    def describe(self) -> str:
        return (f"dipole Earth field along a circular orbit ({self.altitude_km:g} km, {self.inclination_deg:g}°, "
                f"RAAN {self.raan_deg:g}°, u0 {self.arg_latitude_deg:g}°)")


#: The scenario keys of the gravity-gradient torque (each optional: the default is :data:`RAX1_ORBIT`'s orbit).
GRAVITY_GRADIENT_KEYS = {k: v for k, v in ORBIT_KEYS.items() if k != "earth_angle_deg"}


class GravityGradientTorque(TorqueModel):
    """The gravity-gradient torque of a circular orbit (issue 28; seed 004 Table 1 puts it at 3e-8 N m on RAX-1):
    ``tau = 3 mu / r^3 (o x I o)``, ``o`` the nadir in body components, along the orbit the orbit field models use
    (:func:`circular_orbit`, :data:`RAX1_ORBIT`). It depends on the attitude (through ``o``) quadratically, and is
    evaluated at every stage in compiled code (:func:`kernel.gravity_gradient_torque`); ``inertia`` is the body's
    about its centre of mass, body frame."""

    kind = kernel.GRAVITY_GRADIENT
    attitude_dependent = True

    def __init__(self, inertia, *, altitude_km: float = RAX1_ORBIT["altitude_km"],
                 inclination_deg: float = RAX1_ORBIT["inclination_deg"], raan_deg: float = RAX1_ORBIT["raan_deg"],
                 arg_latitude_deg: float = RAX1_ORBIT["arg_latitude_deg"]):
        self.inertia = validate_inertia(inertia)
        self.altitude_km, self.inclination_deg = float(altitude_km), float(inclination_deg)
        self.raan_deg, self.arg_latitude_deg = float(raan_deg), float(arg_latitude_deg)
        self.a, self.n = circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
        self.P = np.concatenate([self.inertia.ravel(), [self.a, self.n, np.radians(self.inclination_deg),
                                                         np.radians(self.raan_deg), np.radians(self.arg_latitude_deg)]])

    def nadir_world(self, t) -> np.ndarray:
        """The nadir direction (world components, unit) at times ``t`` (...,) -> (..., 3)."""
        return -orbit_position(t, self.altitude_km, self.inclination_deg, self.raan_deg, self.arg_latitude_deg) / self.a

    def describe(self) -> str:
        return (f"gravity gradient along a circular orbit ({self.altitude_km:g} km, {self.inclination_deg:g}°, "
                f"RAAN {self.raan_deg:g}°, u0 {self.arg_latitude_deg:g}°)")
