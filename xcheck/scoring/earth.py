"""The local North-East-Down frame of a rotating Earth, along the path of a body that falls through it: what a
flight simulator's Euler angles are relative to (NASA/TM-2015-218675's check cases: ``eulerAngle_deg_Yaw`` is a
yaw-pitch-roll of the body relative to the local NED frame at the vehicle's position).

The scenario's world frame is the inertial frame that coincides with the NED frame at the start (``t = 0``). The NED
frame at a later time differs from it by the Earth's rotation (WGS-84: 7.292115e-5 rad/s about its axis, which at
latitude ``phi`` has NED components ``(cos phi, 0, -sin phi)``) and by the body's own motion over the Earth (its
longitude and latitude change as it falls: the Coriolis acceleration carries a body dropped from rest eastward). The
fall is integrated in the Earth-centred inertial frame under WGS-84 gravity with the J2 term, from rest relative to
the Earth, without air (the check case's brick has no drag).

Conventions: quaternions ``[w, x, y, z]``; :func:`ned_frames` gives ``q`` mapping NED(t) components to world
components (the frame's attitude, as a body's is), and the frame's angular velocity relative to inertial space in
NED(t) components. SI units, angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import rotations as rot

__all__ = ["Earth", "WGS84_RATE", "fall", "ned_frames", "geodetic_to_ecef", "ecef_to_geodetic", "ned_axes"]

#: WGS-84: the semi-major axis [m], flattening, the Earth's rotation rate [rad/s], GM [m^3/s^2], J2 (EGM96, WGS-84's
#: second zonal harmonic, unnormalised).
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_RATE = 7.292115e-5
WGS84_GM = 3.986004418e14
WGS84_J2 = 1.08262668e-3
_E2 = WGS84_F * (2.0 - WGS84_F)


@dataclass(frozen=True)
class Earth:
    """Where the body starts over a rotating Earth and how it moves: geodetic latitude and longitude [rad], height
    above the ellipsoid [m], velocity relative to the Earth in NED components [m/s], the rotation rate [rad/s] and
    ``motion``: ``"fall"`` (integrated under gravity, no air) or ``"fixed"`` (the frame stays at the start point: a
    body held over one place on the Earth)."""

    latitude: float = 0.0
    longitude: float = 0.0
    height: float = 0.0
    velocity_ned: tuple = (0.0, 0.0, 0.0)
    rate: float = WGS84_RATE
    motion: str = "fall"


def geodetic_to_ecef(lat, lon, h) -> np.ndarray:
    """Earth-centred, Earth-fixed position [m] of a geodetic latitude, longitude [rad] and height [m] (WGS-84)."""
    n = WGS84_A / math.sqrt(1.0 - _E2 * math.sin(lat) ** 2)
    return np.array([(n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
                     (n * (1.0 - _E2) + h) * math.sin(lat)])


def ecef_to_geodetic(r) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geodetic latitude, longitude [rad] and height [m] of ECEF positions ``(..., 3)`` (WGS-84; Bowring's
    iteration, converged to rounding in five passes at any height a check case reaches)."""
    r = np.asarray(r, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    lat = np.arctan2(z, p * (1.0 - _E2))
    for _ in range(5):
        n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(lat) ** 2)
        h = p * np.cos(lat) + z * np.sin(lat) - n * (1.0 - _E2 * np.sin(lat) ** 2)
        lat = np.arctan2(z, p * (1.0 - _E2 * n / (n + h)))
    n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(lat) ** 2)
    h = p * np.cos(lat) + z * np.sin(lat) - n * (1.0 - _E2 * np.sin(lat) ** 2)
    return lat, lon, h


def ned_axes(lat, lon) -> np.ndarray:
    """``(..., 3, 3)``: the matrix whose columns are North, East and Down in ECEF components (NED -> ECEF)."""
    lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    north = np.stack([-sl * co, -sl * so, cl], axis=-1)
    east = np.stack([-so, co, np.zeros_like(so)], axis=-1)
    down = np.stack([-cl * co, -cl * so, -sl], axis=-1)
    return np.stack([north, east, down], axis=-1)


def _gravity(r) -> np.ndarray:
    """WGS-84 gravitation with J2 [m/s^2] at the ECI position ``r`` (z along the Earth's axis)."""
    x, y, z = r
    r2 = x * x + y * y + z * z
    rn = math.sqrt(r2)
    k = 1.5 * WGS84_J2 * WGS84_A * WGS84_A / r2
    s = 5.0 * z * z / r2
    c = -WGS84_GM / (r2 * rn)
    return np.array([c * x * (1.0 + k * (1.0 - s)), c * y * (1.0 + k * (1.0 - s)), c * z * (1.0 + k * (3.0 - s))])


def fall(earth: Earth, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geodetic latitude, longitude [rad] and their rates [rad/s] of the body at times ``t`` [s] (``earth.motion``:
    ``"fall"`` integrated with DOP853 at a relative tolerance of 1e-12 in the ECI frame, which coincides with the
    ECEF frame at ``t = 0``; ``"fixed"``: the start point, rates zero). Returns ``(lat, lon, rates (n, 2))``."""
    t = np.asarray(t, dtype=float)
    if earth.motion == "fixed" or len(t) == 0:
        return (np.full(t.shape, earth.latitude), np.full(t.shape, earth.longitude), np.zeros(t.shape + (2,)))
    from scipy.integrate import solve_ivp

    r0 = geodetic_to_ecef(earth.latitude, earth.longitude, earth.height)
    spin = np.array([0.0, 0.0, earth.rate])
    v0 = ned_axes(earth.latitude, earth.longitude) @ np.asarray(earth.velocity_ned, dtype=float) + np.cross(spin, r0)

    def rhs(_, y):
        return np.concatenate([y[3:], _gravity(y[:3])])

    end = float(t.max())
    if end <= 0.0:
        rates = np.zeros(t.shape + (2,))
        return np.full(t.shape, earth.latitude), np.full(t.shape, earth.longitude), rates
    sol = solve_ivp(rhs, (0.0, end), np.concatenate([r0, v0]), method="DOP853", rtol=1e-12, atol=1e-6,
                    dense_output=True)
    y = sol.sol(t).T  # (n, 6) ECI
    angle = earth.rate * t
    c, s = np.cos(angle), np.sin(angle)
    r = np.stack([c * y[:, 0] + s * y[:, 1], -s * y[:, 0] + c * y[:, 1], y[:, 2]], axis=-1)  # ECEF
    v = np.stack([c * y[:, 3] + s * y[:, 4], -s * y[:, 3] + c * y[:, 4], y[:, 5]], axis=-1) - np.cross(spin, r)
    lat, lon, _ = ecef_to_geodetic(r)
    lon_rate = (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]) / (r[:, 0] ** 2 + r[:, 1] ** 2)
    # the geodetic latitude's rate: the velocity's northward component over the meridian radius plus height
    n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(lat) ** 2)
    m = n * (1.0 - _E2) / (1.0 - _E2 * np.sin(lat) ** 2)
    _, _, h = ecef_to_geodetic(r)
    v_north = np.einsum("ni,ni->n", ned_axes(lat, lon)[..., 0], v)
    lat_rate = v_north / (m + h)
    return lat, lon, np.stack([lat_rate, lon_rate], axis=-1)


def ned_frames(earth: Earth, t) -> tuple[np.ndarray, np.ndarray]:
    """The local NED frame along the body's path at times ``t``: ``q (n, 4)`` mapping NED(t) components to world
    components (the world is the inertial frame that is NED at ``t = 0``), and its angular velocity relative to
    inertial space in NED(t) components ``(n, 3)``: ``((w_E + lon') cos lat, -lat', -(w_E + lon') sin lat)``."""
    t = np.asarray(t, dtype=float)
    lat, lon, rates = fall(earth, t)
    angle = earth.rate * t
    c, s, z = np.cos(angle), np.sin(angle), np.zeros_like(angle)
    spin = np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, z + 1.0], -1)], axis=-2)
    eci_from_ned = spin @ ned_axes(lat, lon)  # Rz(w_E t) R_ecef<-ned
    world_from_ned = ned_axes(earth.latitude, earth.longitude).T @ eci_from_ned
    q = rot.dcm_to_quat(world_from_ned)
    turn = earth.rate + rates[:, 1]
    omega = np.stack([turn * np.cos(lat), -rates[:, 0], -turn * np.sin(lat)], axis=-1)
    return q, omega
