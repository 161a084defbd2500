"""The surface forces of low Earth orbit (issue 28; seed 004 Table 1 puts them at 2e-8 N m, solar pressure, and
2e-9 N m, aerodynamic, on RAX-1): each a force through a centre of pressure offset from the centre of mass,
``tau = c x (R^T F)`` in body components, with the simplest models that are stated whole:

* **Solar radiation pressure** (:class:`SolarPressureTorque`): ``F = -P C_r A s``, the sun in a fixed inertial
  direction ``s`` over the run (the sun moves 1 degree a day), ``P`` = 4.56e-6 N/m^2 at 1 AU, a constant
  projected area ``A`` and a reflectivity coefficient ``C_r`` (1 absorbs everything, 2 mirrors it back), no
  eclipse, no dependence of ``A`` or ``c`` on the attitude. A constant force fixed in the world through a fixed
  offset: the form of a top under gravity, so its energy with a potential, its momentum along ``s`` and, for a body
  symmetric about ``c``, Lagrange's closed form hold.
* **Aerodynamic drag** (:class:`AerodynamicTorque`): ``F = -1/2 rho v^2 C_d A v^``, ``v`` the circular orbit's
  speed along its velocity ``v^`` (the orbit of the field models; the atmosphere's co-rotation, winds and the
  spacecraft's own rate neglected), a constant density ``rho``, drag coefficient ``C_d`` and projected area ``A``.
  The force turns with the orbit (once per orbit).

What they leave out, said once: the projected area and centre of pressure of a real body change with the attitude
(a flat plate's ``A |n.v^|`` has a kink where it turns edge-on, which costs a fixed-step method its order; these
constant-area models keep the torque smooth), the density varies by an order of magnitude with solar activity and
along the orbit, and the sun is eclipsed for up to a third of a LEO orbit. They give the size and the form of the
torques, which is what a cross-check of integrators needs; a mission's analysis needs its own surface model.
Both are evaluated by the compiled kernel of a dipole in a field (``c`` for the dipole, ``F / mu0`` for the field).
"""

from __future__ import annotations

import numpy as np

from . import kernel
from .models import Field, MagneticTorque, UniformField, _vector3
from .orbit import RAX1_ORBIT, circular_orbit

__all__ = ["SolarPressureTorque", "AerodynamicTorque", "SOLAR_PRESSURE_1AU", "LEO_DENSITY"]

#: Solar radiation pressure at 1 AU [N/m^2] (1361 W/m^2 over c).
SOLAR_PRESSURE_1AU = 4.56e-6
#: A density of the atmosphere at 650 km [kg/m^3], moderate solar activity (1e-14 to 1e-12 over a cycle).
LEO_DENSITY = 1e-13


def _positive(name: str, value, unit: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name}: expected a positive value in {unit}, got {value!r}")
    return value


class SolarPressureTorque(MagneticTorque):
    """``c x (R^T F)`` with ``F = -P C_r A s`` fixed in the world (see the module docstring)."""

    def __init__(self, centre_of_pressure, area, *, reflectivity: float = 1.5, pressure: float = SOLAR_PRESSURE_1AU,
                 sun_direction=(1.0, 0.0, 0.0)):
        self.centre = _vector3("centre_of_pressure", centre_of_pressure, "m")
        self.area = _positive("area", area, "m^2")
        self.reflectivity = float(reflectivity)
        if not 1.0 <= self.reflectivity <= 2.0:
            raise ValueError(f"reflectivity: expected C_r from 1 (absorbing) to 2 (a mirror), got {reflectivity!r}")
        self.pressure = _positive("pressure", pressure, "N/m^2")
        s = _vector3("sun_direction", sun_direction, "(a direction)")
        if not np.any(s):
            raise ValueError("sun_direction: expected a direction, got [0, 0, 0]")
        self.sun = s / np.linalg.norm(s)
        with np.errstate(over="ignore"):
            self.force = -self.pressure * self.reflectivity * self.area * self.sun
            _check_force("pressure x reflectivity x area", float(np.max(np.abs(self.force))))
        super().__init__(self.centre, UniformField(self.force / kernel.MU0))

    def describe(self) -> str:
        return (f"solar pressure {np.linalg.norm(self.force):.3g} N away from the sun {np.round(self.sun, 6).tolist()} "
                f"through the centre of pressure {self.centre.tolist()} m")


def _check_force(what: str, size: float) -> None:
    """A surface force [N] whose inputs' product overflows (or reaches the compiled field's overflow, as a field
    strength of force / mu0) is a ValueError naming the inputs."""
    if not size / kernel.MU0 < 1e300:
        raise ValueError(f"{what}: the force is {size:.3g} N, which overflows: give physical sizes")


class OrbitFlow(Field):
    """The drag force of :class:`AerodynamicTorque` as the compiled evaluators' field: ``scale v^(t)`` [A/m] with
    ``mu0 scale`` the force's size, along a circular orbit's velocity (world components)."""

    name = "orbit-flow"
    slots = ("scale", "mean_motion", "inclination", "raan", "arg_latitude0")
    frame = "world"
    evaluator = kernel.ORBIT_FLOW

    def __init__(self, scale: float, n: float, inclination: float, raan: float, u0: float):
        self.values = [float(scale), float(n), float(inclination), float(raan), float(u0)]

    def slot_values(self):
        return dict(zip(self.slots, self.values))

    def strength(self, t) -> np.ndarray:
        """``scale v^(t)`` at times ``t`` (...,) -> (..., 3): :func:`.kernel.orbit_velocity_direction`'s formula."""
        scale, n, inc, raan, u0 = self.values
        u = u0 + n * np.asarray(t, dtype=float)
        cu, su, ci, si, cO, sO = np.cos(u), np.sin(u), np.cos(inc), np.sin(inc), np.cos(raan), np.sin(raan)
        return scale * np.stack([-cO * su - sO * cu * ci, -sO * su + cO * cu * ci, cu * si], axis=-1)


class AerodynamicTorque(MagneticTorque):
    """``c x (R^T F)`` with ``F = -1/2 rho v^2 C_d A v^`` along a circular orbit (see the module docstring)."""

    def __init__(self, centre_of_pressure, area, *, density: float = LEO_DENSITY, drag_coefficient: float = 2.2,
                 altitude_km: float = RAX1_ORBIT["altitude_km"], inclination_deg: float = RAX1_ORBIT["inclination_deg"],
                 raan_deg: float = RAX1_ORBIT["raan_deg"], arg_latitude_deg: float = RAX1_ORBIT["arg_latitude_deg"]):
        self.centre = _vector3("centre_of_pressure", centre_of_pressure, "m")
        self.area = _positive("area", area, "m^2")
        self.density = _positive("density", density, "kg/m^3")
        self.drag_coefficient = _positive("drag_coefficient", drag_coefficient, "(dimensionless)")
        a, n = circular_orbit(altitude_km, inclination_deg, raan_deg, arg_latitude_deg)
        self.speed = a * n
        with np.errstate(over="ignore"):
            self.drag = 0.5 * self.density * self.speed**2 * self.drag_coefficient * self.area  # [N]
            _check_force("density x drag_coefficient x area", self.drag)
        self.altitude_km = float(altitude_km)
        super().__init__(self.centre, OrbitFlow(-self.drag / kernel.MU0, n, np.radians(inclination_deg),
                                                np.radians(raan_deg), np.radians(arg_latitude_deg)))

    def describe(self) -> str:
        return (f"aerodynamic drag {self.drag:.3g} N against the orbit's velocity ({self.altitude_km:g} km, "
                f"{self.speed:.0f} m/s, rho {self.density:.3g} kg/m^3) through the centre of pressure "
                f"{self.centre.tolist()} m")
