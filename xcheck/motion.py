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

Core: numpy only."""

from __future__ import annotations

import numpy as np

from .body import principal_axes

__all__ = ["tumbles", "resolves_flips", "intermediate_rate", "crossings", "refined_crossings", "flips_of", "flip_summary",
           "FLIPS_HOW", "FLIP_RESOLUTION"]

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
