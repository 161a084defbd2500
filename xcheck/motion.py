"""The motion's own numbers (issue 62): what a user counts by hand and asks of each method — does it get the motion?

**A tumbling body's flips** (the tennis-racket or Dzhanibekov effect). A body set spinning nearest its intermediate
principal axis (the middle moment) turns over again and again; at each flip the body rate about that axis changes
sign. Torque free, that rate is a Jacobi ``cn`` (or ``sn``) of period ``4 K(m) / lam`` (Landau & Lifshitz §37;
:func:`xcheck.reference.elliptic_period`), so the body flips every ``2 K(m) / lam``: half the rate's period.

How it is measured, the same way on every trajectory: the times where the rate about the intermediate axis
(``V[:, 1] · ω``, body components, ``V`` the principal axes of :func:`xcheck.body.principal_axes`) changes sign,
each placed by linear interpolation between the two samples around it. The rate passes zero at an inflection
(``cn'' = 0`` where ``cn = 0``), so the placement's own error is of third order in the step: at 1/60 s on a 1.4 s
flip, below 1e-6 s. **Every** is the mean time between successive flips, ``(t_n - t_1) / (n - 1)`` (None with fewer
than two flips); **first** the time of the first flip [s]. The reference's flips are placed on the reference itself
to round-off (bisection between the samples that bracket them: :func:`refined_crossings`).

**A top's precession and nutation** (Lagrange's top: a body symmetric about the axis through its centre of mass,
under a torque ``c x (R^T F)``: gravity about a pivot, or a dipole in a field fixed in the world), and a torque-free
axisymmetric body's coning. The symmetry axis ``a = R(q) e`` in the world, against the pole ``p`` (the top's: ``-F``,
up for gravity; the torque-free body's: its angular momentum ``L``): ``u = a · p`` (the cosine of the nutation
angle) and the azimuth of ``a`` about ``p`` (right-handed about ``p``, unwrapped). **Nutation**: ``u`` oscillates
between the roots of Lagrange's cubic; its period is the mean time between successive upward crossings of the
middle of the reference's range of ``u`` (placed between samples, as the flips), None where ``u`` does not
oscillate (a steady precession, a torque-free cone). **Precession**: the mean rate of the azimuth [rad/s], over
the whole nutation periods between the first and the last of those crossings (the mean over a period is the
motion's own number), over the whole run where there are fewer than two. **The cone's change** (a wobble's decay):
the angle between the axis and the pole, its mean over the last whole nutation period less over the first, or at
the end less at the start without nutation [rad]: + the cone widened, - it narrowed; the reference's is 0 up to its
own accuracy (the exact motion keeps the cone, or repeats it each nutation period). All are measured where a run's
step is at most 1/32 of the reference's nutation period (of its precession period without nutation).

Core: numpy only."""

from __future__ import annotations

import numpy as np

from . import rotations as rot
from .body import principal_axes

__all__ = ["top_frame", "cone_of", "precession_of", "precession_summary", "resolves_precession", "PRECESSION_HOW",
           "tumbles", "resolves_flips", "intermediate_rate", "crossings", "refined_crossings", "flips_of",
           "flip_summary", "FLIPS_HOW", "FLIP_RESOLUTION", "nutation_level", "NARROWEST_CONE", "LEAST_NUTATION"]

#: How the flips are measured, in one sentence (the terminal's, the report's and the JSON's).
FLIPS_HOW = ("a flip is where the body rate about the intermediate principal axis changes sign, placed by linear "
             "interpolation between samples (third order in the step: the rate passes zero at an inflection); "
             "'every' is the mean time between successive flips; measured where a run's step is at most 1/32 of the "
             "time between the reference's flips")
#: A run's samples place its flips where its step is at most this fraction of the time between the reference's flips.
FLIP_RESOLUTION = 1 / 32
#: Moments closer than this, relative to the largest, have no intermediate axis to tumble about.
DISTINCT_MOMENTS_RTOL = 1e-6


def tumbles(inertia, omega0) -> bool:
    """Whether a body starts spinning nearest its intermediate axis (of three distinct moments): the motion whose
    flips are counted. The component of ``L = I ω0`` about that axis is the largest of the three."""
    J, V = principal_axes(np.asarray(inertia, dtype=float))
    if min(J[1] - J[0], J[2] - J[1]) <= DISTINCT_MOMENTS_RTOL * J[2]:
        return False
    L = np.abs(J * (V.T @ np.asarray(omega0, dtype=float)))
    return bool(L[1] > 0 and L[1] >= L.max())


def resolves_flips(dt: float, reference: dict | None) -> bool:
    """Whether a run sampled every ``dt`` [s] places flips (:data:`FLIP_RESOLUTION`) of the ``reference``'s
    :func:`flip_summary` (its time between flips; twice its first flip's time where it flips once)."""
    if not reference or not reference["flips"]:
        return False
    interval = reference["every"] if reference["every"] is not None else 2 * reference["first"]
    return dt <= FLIP_RESOLUTION * interval


def intermediate_rate(inertia, omega) -> np.ndarray:
    """The body rate about the intermediate principal axis [rad/s], per sample of ``omega`` (n, 3) body rates."""
    _, V = principal_axes(np.asarray(inertia, dtype=float))
    return np.asarray(omega, dtype=float) @ V[:, 1]


def _brackets(x) -> np.ndarray:
    """Indices ``i`` where ``x`` changes sign between samples ``i`` and ``i + 1`` (a sample at exactly zero counts once,
    at the interval that reaches it)."""
    x = np.asarray(x, dtype=float)
    return np.flatnonzero((x[:-1] * x[1:] < 0) | ((x[1:] == 0) & (x[:-1] != 0)))


def crossings(t, x) -> np.ndarray:
    """The times where the samples ``x`` of ``t`` change sign, each by linear interpolation between its two samples."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    i = _brackets(x)
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def refined_crossings(f, t, iterations: int = 64) -> np.ndarray:
    """The sign changes of ``f`` (a function of a time array, vectorised) bracketed by the grid ``t``, each bisected to
    round-off (every bracket at once: one call of ``f`` an iteration)."""
    t = np.asarray(t, dtype=float)
    i = _brackets(f(t))
    lo, hi = t[i].copy(), t[i + 1].copy()
    if not len(i):
        return lo
    f_lo = f(lo)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if np.all((mid == lo) | (mid == hi)):
            break
        f_mid = f(mid)
        left = np.sign(f_mid) == np.sign(f_lo)
        lo, f_lo = np.where(left, mid, lo), np.where(left, f_mid, f_lo)
        hi = np.where(left, hi, mid)
    return 0.5 * (lo + hi)


def flip_summary(times) -> dict:
    """``{"flips": n, "first": t_1 [s] or None, "every": mean interval [s] or None}`` of flip times (see the module)."""
    times = np.asarray(times, dtype=float)
    n = len(times)
    return {"flips": n, "first": float(times[0]) if n else None,
            "every": float((times[-1] - times[0]) / (n - 1)) if n > 1 else None}


def flips_of(inertia, t, omega) -> dict:
    """:func:`flip_summary` of a trajectory's samples (``t`` (n,) [s], ``omega`` (n, 3) body rates [rad/s])."""
    return flip_summary(crossings(t, intermediate_rate(inertia, omega)))


#: How the precession and nutation are measured, in one sentence (the terminal's, the report's and the JSON's).
PRECESSION_HOW = ("the symmetry axis in the world against the pole (a top's vertical, -F; a torque-free body's angular "
                  "momentum): precession is the mean rate of its azimuth about the pole over whole nutation periods "
                  "(over the run without nutation), right-handed about the pole; the nutation period the mean time "
                  "between upward crossings of the middle of the reference's range of the axis' height")
#: A cone narrower than this [rad] has no azimuth to measure (the axis along the pole: a sleeping top).
NARROWEST_CONE = 1e-6
#: The least range of the axis' height that counts as a nutation (below: a steady precession, a torque-free cone).
LEAST_NUTATION = 1e-9


def top_frame(inertia, q0, omega0, torque=None):
    """``(axis, pole)`` of a top or an axisymmetric body (see the module): the symmetry axis ``e`` (body components,
    unit) and the pole ``p`` (world, unit); None for any other body or torque, or a cone narrower than
    :data:`NARROWEST_CONE` at the start."""
    from .reference import EQUAL_MOMENTS_RTOL, exact_why_not

    I = np.asarray(inertia, dtype=float)
    if torque is None:
        J, V = principal_axes(I)
        if J[1] - J[0] <= EQUAL_MOMENTS_RTOL * J[2] < J[2] - J[1]:
            axis = V[:, 2]
        elif J[2] - J[1] <= EQUAL_MOMENTS_RTOL * J[2] < J[1] - J[0]:
            axis = V[:, 0]
        else:
            return None
        L = rot.quat_rotate(np.asarray(q0, dtype=float), I @ np.asarray(omega0, dtype=float))
        if not np.any(L):
            return None
        pole = L / np.linalg.norm(L)
    else:
        form = torque.fixed_form() if hasattr(torque, "fixed_form") else None
        if form is None or getattr(torque, "conserves_momentum", False) or exact_why_not(I, torque) is not None:
            return None
        centre, force = (np.asarray(v, dtype=float) for v in form)
        axis, pole = centre / np.linalg.norm(centre), -force / np.linalg.norm(force)
    a0 = rot.quat_rotate(np.asarray(q0, dtype=float), axis)
    if np.linalg.norm(np.cross(a0, pole)) < NARROWEST_CONE:
        return None
    return axis, pole


def cone_of(q, axis, pole):
    """``(u, azimuth)`` per sample of ``q`` (n, 4): the axis' height ``a · p`` and its azimuth about ``p`` [rad],
    unwrapped (see the module)."""
    q = np.asarray(q, dtype=float)
    w, v = q[:, :1] / np.linalg.norm(q, axis=1, keepdims=True), q[:, 1:] / np.linalg.norm(q, axis=1, keepdims=True)
    t = 2.0 * np.cross(v, axis)
    a = axis + w * t + np.cross(v, t)  # R(q) e without the checks of rotations.quat_rotate (a run's own rows)
    e1 = np.cross(pole, [1.0, 0.0, 0.0] if abs(pole[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(pole, e1)
    return a @ pole, np.unwrap(np.arctan2(a @ e2, a @ e1))


def precession_summary(t, u, azimuth, level: float | None) -> dict:
    """``{"precession": rate [rad/s], "nutation_period": [s] or None, "nutations": whole periods measured,
    "cone_change": [rad]}`` of the samples (see the module); ``level``: the middle of the reference's range of ``u``
    (None: no nutation). ``cone_change``: how far the cone (the angle between the axis and the pole) widened (+) or
    narrowed (-): its mean over the last nutation period less over the first (0 with fewer than two), or its end less
    its start without nutation: a wobble's decay."""
    t = np.asarray(t, dtype=float)
    up = np.array([])
    if level is not None:
        x = np.asarray(u, dtype=float) - level
        i = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
        up = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    cone = np.arccos(np.clip(np.asarray(u, dtype=float), -1.0, 1.0))
    if len(up) > 1:
        phi = np.interp(up[[0, -1]], t, azimuth)
        return {"precession": float((phi[1] - phi[0]) / (up[-1] - up[0])),
                "nutation_period": float((up[-1] - up[0]) / (len(up) - 1)), "nutations": len(up) - 1,
                "cone_change": (_mean_over(t, cone, up[-2], up[-1]) - _mean_over(t, cone, up[0], up[1])
                                if len(up) > 2 else 0.0)}
    return {"precession": float((azimuth[-1] - azimuth[0]) / (t[-1] - t[0])), "nutation_period": None,
            "nutations": 0, "cone_change": float(cone[-1] - cone[0])}


def _mean_over(t, x, a: float, b: float) -> float:
    """The mean of the samples ``x`` of ``t`` over ``[a, b]`` (trapezoids, the ends interpolated)."""
    inside = (t > a) & (t < b)
    tt = np.concatenate([[a], t[inside], [b]])
    xx = np.concatenate([[np.interp(a, t, x)], x[inside], [np.interp(b, t, x)]])
    return float(np.sum(0.5 * (xx[1:] + xx[:-1]) * np.diff(tt)) / (b - a))


def nutation_level(u) -> float | None:
    """The middle of the range of the reference's ``u``, None where it does not nutate (:data:`LEAST_NUTATION`)."""
    lo, hi = float(np.min(u)), float(np.max(u))
    return None if hi - lo < LEAST_NUTATION else 0.5 * (lo + hi)


def precession_of(t, q, frame, level: float | None) -> dict:
    """:func:`precession_summary` of a trajectory (``frame``: :func:`top_frame`'s)."""
    u, azimuth = cone_of(q, *frame)
    return precession_summary(t, u, azimuth, level)


def resolves_precession(dt: float, reference: dict | None) -> bool:
    """Whether a run sampled every ``dt`` [s] measures the ``reference``'s precession and nutation: ``dt`` at most
    1/32 of its nutation period, or of its precession's period without one."""
    if not reference:
        return False
    period = reference["nutation_period"] or (2 * np.pi / abs(reference["precession"]) if reference["precession"]
                                              else None)
    return period is not None and dt <= FLIP_RESOLUTION * period
