"""The sensors of an attitude-determination study and their set-up (a scenario's ``[determination]`` table;
the study itself is :mod:`xcheck.determination.study`): the noise model, the observations of one noise level, and the
error the noise predicts (Shuster's covariance). Plain numpy: no engine, no study."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fields.kernel import MU0
from . import methods as det

__all__ = ["NoiseLevel", "DeterminationSpec", "DEFAULT_SPEC", "read_determination", "observe", "predicted_rms",
           "MU0", "PREDICTION_BAND", "EXACT_TOL"]

#: An optimal method's RMS error must be within this factor of the predicted (statistics over ~600 samples of
#: three axes put 1 sigma at ~2 %; the first-order prediction is the rest).
PREDICTION_BAND = (0.85, 1.15)
#: Noise-free, every method must recover the truth to this [rad] (round-off).
EXACT_TOL = 1e-10


@dataclass(frozen=True)
class NoiseLevel:
    name: str
    magnetometer_nT: float
    sun_deg: float

    @property
    def noise_free(self) -> bool:
        return self.magnetometer_nT == 0 and self.sun_deg == 0


@dataclass(frozen=True)
class DeterminationSpec:
    method: str = "mujoco-rk4"
    dt: float = 1 / 64
    seed: int = 2
    sun_direction: tuple = (0.0, 0.0, 1.0)
    levels: tuple = (NoiseLevel("noise-free", 0.0, 0.0), NoiseLevel("fine sensors", 50.0, 0.05),
                     NoiseLevel("coarse sensors", 500.0, 1.0))
    methods: tuple = tuple(det.METHODS)
    approach_angles_deg: tuple = (90.0, 45.0, 20.0, 10.0, 5.0, 2.0, 1.0, 0.5, 0.2, 0.1)
    approach_noise: str = "fine sensors"


DEFAULT_SPEC = DeterminationSpec()


#: The closest the sun may come to the field's direction [deg], in the approach study or (a uniform field) in
#: the scenario: closer, the two directions are parallel for the solvers' arithmetic (the predicted error's
#: information matrix goes singular), and no attitude can be determined.
MIN_ANGLE_DEG = 1e-3
#: A noisy sensor's standard deviations: beyond the largest, the reading is noise (a LEO field is 2e4-6e4 nT);
#: below the smallest, none has been built, and the weights 1/σ² would overflow.
MAGNETOMETER_NT = (1e-6, 1e4)
SUN_DEG = (1e-6, 10.0)


def read_determination(reader, duration: float, torque: dict | None = None) -> DeterminationSpec:
    """The ``[determination]`` table through a :class:`xcheck.scenario._Reader` (errors name file and key).
    ``torque``: the scenario's [torque] table; a uniform field's direction is checked against the sun's."""
    from ..runners import RUNNERS, unknown_method
    from ..trajectory import check_step

    d = DEFAULT_SPEC
    method = reader.get("method", "string", d.method)
    if method not in RUNNERS:
        reader.fail("method", unknown_method(method))
    dt = reader.positive("dt", d.dt)
    try:
        check_step(dt, duration)
    except ValueError as exc:
        reader.fail("dt", str(exc))
    seed = reader.get("seed", "integer", d.seed)
    if seed < 0:
        reader.fail("seed", f"expected a non-negative whole number, got {seed}")
    sun = reader.get("sun_direction", ("vector", 3), np.array(d.sun_direction))
    if not np.max(np.abs(sun)) > 0:
        reader.fail("sun_direction", "a zero vector has no direction")
    sun = sun / np.max(np.abs(sun))  # any length: 1e308 components would overflow the norm below
    methods = tuple(reader.get("methods", "strings", list(d.methods)))
    for m in methods:
        if m not in det.METHODS:
            reader.fail("methods", f"unknown method {m!r}; expected any of {', '.join(det.METHODS)}")
    if not methods or len(set(methods)) != len(methods):
        reader.fail("methods", f"expected distinct methods, at least one, got {list(methods)}")
    levels = d.levels
    if reader.has("noise"):
        raw = reader.get("noise", "list")
        if not raw or not all(isinstance(x, dict) for x in raw):
            reader.fail("noise", "expected [[determination.noise]] tables (name, magnetometer_nT, sun_deg)")
        levels = []
        for i, table in enumerate(raw):
            sub = type(reader)(reader.path, table, f"{reader.section}.noise #{i + 1}")
            name = sub.get("name", "string", required=True)
            mag = sub.get("magnetometer_nT", "number", required=True)
            sun_deg = sub.get("sun_deg", "number", required=True)
            sub.finish()
            if mag < 0 or sun_deg < 0:
                sub.fail("magnetometer_nT" if mag < 0 else "sun_deg", "a standard deviation cannot be negative")
            if (mag == 0) != (sun_deg == 0):
                sub.fail("sun_deg" if sun_deg == 0 else "magnetometer_nT",
                         "a noise-free sensor beside a noisy one would get infinite weight; give both a standard "
                         "deviation, or neither")
            for key, value, (low, high), unit, what in (
                    ("magnetometer_nT", mag, MAGNETOMETER_NT, " nT", "a magnetometer's"),
                    ("sun_deg", sun_deg, SUN_DEG, "°", "a sun sensor's")):
                if value != 0 and not low <= value < high:
                    sub.fail(key, f"{value:g}{unit} is {'beyond' if value >= high else 'below'} {what} noise "
                                  f"(expected 0, or {low:g}{unit} up to under {high:g}{unit})")
            if any(lv.name == name for lv in levels):
                sub.fail("name", f"two noise levels are named {name!r}")
            levels.append(NoiseLevel(name, mag, sun_deg))
        levels = tuple(levels)
    angles = tuple(reader.get("approach_angles_deg", "numbers", list(d.approach_angles_deg)))
    if not all(MIN_ANGLE_DEG <= a <= 90 for a in angles):
        reader.fail("approach_angles_deg", f"expected angles from {MIN_ANGLE_DEG:g} to 90 degrees (closer, the sun "
                                           f"and the field are parallel for the solvers), got {list(angles)}")
    from ..torque_terms import magnetic_term

    torque = magnetic_term(torque)
    if torque is not None and torque.get("field") == "uniform" and "H_world" in torque:
        H = np.asarray(torque["H_world"], dtype=float)
        u = sun / np.linalg.norm(sun)
        if np.linalg.norm(H) > 0:
            angle = np.degrees(np.arccos(np.clip(abs(u @ H) / np.linalg.norm(H), -1.0, 1.0)))
            if angle < MIN_ANGLE_DEG:
                reader.fail("sun_direction", f"{sun.tolist()} is {'anti' if u @ H < 0 else ''}parallel to the uniform "
                                             f"field H_world = {H.tolist()} (within {angle:.2g}°): the two directions "
                                             "fix no attitude; turn one of them")
    noisy = [lv.name for lv in levels if not lv.noise_free]
    approach = reader.get("approach_noise", "string", d.approach_noise if d.approach_noise in noisy else None)
    if approach is None and noisy:
        approach = noisy[0]
    if noisy and approach not in noisy:
        reader.fail("approach_noise", f"expected one of the noisy levels {noisy}, got {approach!r}")
    reader.finish()
    return DeterminationSpec(method=method, dt=dt, seed=seed, sun_direction=tuple(float(x) for x in sun / np.linalg.norm(sun)),
                             levels=levels, methods=methods, approach_angles_deg=angles,
                             approach_noise=approach if noisy else None)


# --------------------------------------------------------------------------------------------------------
# sensors, noise, prediction (pure numpy)
# --------------------------------------------------------------------------------------------------------
def _perpendicular_noise(u, sigma, rng):
    """``u`` (T, 3) unit, turned by a Gaussian angle ``sigma`` [rad] about each axis perpendicular to it."""
    n = rng.standard_normal(u.shape)
    n -= np.sum(n * u, axis=-1, keepdims=True) * u
    v = u + sigma * n
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def observe(B_body, B_world, sun_world, R, level: NoiseLevel, rng):
    """The observations of one noise level at T samples: ``b``, ``r`` (T, 2, 3) unit, ``w`` (T, 2) and the
    angular sigmas (T, 2) [rad], the more accurate sensor first. ``B_body`` (T, 3) [T] is the magnetometer's
    noise-free reading, ``B_world`` (T, 3) [T] the field model's, ``sun_world`` (T, 3) unit, ``R`` (T, 3, 3)
    body -> world (the truth)."""
    T = len(B_body)
    sun_body = np.einsum("tji,tj->ti", R, sun_world)
    B_meas = B_body + level.magnetometer_nT * 1e-9 * rng.standard_normal(B_body.shape)
    mag = B_meas / np.linalg.norm(B_meas, axis=-1, keepdims=True)
    sigma_mag = level.magnetometer_nT * 1e-9 / np.linalg.norm(B_body, axis=-1)
    sigma_sun = np.full(T, np.radians(level.sun_deg))
    sun = _perpendicular_noise(sun_body, sigma_sun[:, None], rng) if level.sun_deg else sun_body
    r_mag = B_world / np.linalg.norm(B_world, axis=-1, keepdims=True)
    sun_first = np.mean(sigma_sun) <= np.mean(sigma_mag)
    pairs = [(sun, sun_world, sigma_sun), (mag, r_mag, sigma_mag)]
    if not sun_first:
        pairs.reverse()
    b = np.stack([p[0] for p in pairs], axis=1)
    r = np.stack([p[1] for p in pairs], axis=1)
    sig = np.stack([p[2] for p in pairs], axis=1)
    if level.noise_free:
        w = np.full((T, 2), 0.5)
    else:
        w = 1 / sig**2
        w = w / w.sum(axis=1, keepdims=True)
    return b, r, w, sig, ("sun sensor" if sun_first else "magnetometer")


def predicted_rms(b_true, sigma) -> np.ndarray:
    """``sqrt(tr P)`` per sample, ``P = [sum_k sigma_k^-2 (I - b_k b_k^T)]^-1`` (Shuster's QUEST measurement
    model): the optimal estimators' RMS attitude error [rad]. ``b_true`` (T, N, 3) unit, ``sigma`` (T, N)."""
    F = np.einsum("tk,tkij->tij", sigma**-2.0, np.eye(3) - np.einsum("tki,tkj->tkij", b_true, b_true))
    trace = np.trace(np.linalg.inv(F), axis1=-2, axis2=-1)
    if not np.all(np.isfinite(trace) & (trace > 0)):  # a sample whose true directions are parallel: no attitude
        raise np.linalg.LinAlgError("the information matrix is singular at a sample")
    return np.sqrt(trace)


