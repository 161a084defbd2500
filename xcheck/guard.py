"""The guard (issue 36): an exact reference checked before it judges.

Every study whose reference is a closed form (:mod:`xcheck.reference`) first compares it, at times of the study's own
grids (:func:`guard_times`), with an independent integration of the same equations: the compiled DOP853
(:mod:`xcheck.integrators.dop853`). Within :data:`GUARD_BOUND` the closed form is used; where they differ by more, the
check's own uncertainty is measured (DOP853's error, from a second run; the motion's conditioning, from perturbed
runs) and the closed form is used if it agrees within that; otherwise the study's reference is the DOP853 run, and
the :class:`ReferenceCheck` says why. Its cost: milliseconds a scenario (13 ms for the nine bundled exact ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotations as rot
from .body import principal_axes
from .reference import _DOP853_STEPS_PER_RAD, ReferenceFailure, _inputs, exact_kind, exact_reference

__all__ = ["check_exact", "stand_in", "ReferenceCheck", "guard_times", "GUARD_BOUND", "GUARD_POINTS", "CONDITIONING_ULPS"]


#: An exact reference farther than this [rad] from its independent check is not used (unless the check itself is
#: less certain than that: :data:`CONDITIONING_ULPS`).
GUARD_BOUND = 1e-11
#: The check compares the closed form with the compiled DOP853 at this many times of the study's own grids.
GUARD_POINTS = 16
#: The compiled DOP853 of the check: rtol (scipy's smallest, 100 eps) and atol; a second run at SPREAD_RTOL, whose
#: difference from the first estimates the first's own error where they disagree.
GUARD_RTOL, GUARD_ATOL = 2.5e-14, 2.5e-16
SPREAD_RTOL, SPREAD_ATOL = 1e-13, 1e-15
#: ... that spread times this is taken as DOP853's own error (its two runs' errors are correlated: on a body turning
#: at 100 rad/s, 2.6e-11 rad from mpmath's 25-digit truth where the two differed by 1.4e-11, and the closed form 5e-12).
SPREAD_FACTOR = 8
#: Where the two disagree by more than GUARD_BOUND, the motion's conditioning is measured too: how far a relative
#: change of CONDITIONING_STEP in each principal moment (relative to the tensor's norm: a turned tensor's moments are
#: known to a few ulps of it) and in each component of the body rate moves it, per unit change. Times machine epsilon,
#: that is what the last bit of the body and its state is worth; no double-precision computation of this motion is
#: taken as more certain than CONDITIONING_ULPS of it. (Measured on 3600 thin, near-separatrix and fast bodies of
#: tests/families.py: the closed form and DOP853 differ by at most 0.63 of the bound this makes, 160 ulps of the
#: conditioning; mpmath at 25 digits showed the closed form the nearer to the truth where they differ.)
CONDITIONING_STEP = 1e-8
CONDITIONING_ULPS = 128
#: The guard's DOP853 takes at most this many steps (a fallback keeps its dense output: 456 bytes a step).
GUARD_MAX_STEPS = 200_000


@dataclass
class ReferenceCheck:
    """What the guard found: the closed form (``kind``) against the compiled DOP853 at ``times`` times of the study's
    grids. ``difference`` the largest attitude difference [rad] (at ``at_time`` [s]); ``uncertainty`` the check's
    own (DOP853's spread between two tolerances, and the motion's conditioning in ulps: measured only where they
    disagree by more than :data:`GUARD_BOUND`; 0 where not measured); ``conditioning`` [rad] what the last bit of the
    body and its state is worth (None: not measured); ``bound`` = max(GUARD_BOUND, uncertainty); ``passed``: the
    closed form is used. Otherwise ``why`` says why not, and ``solution`` (the compiled DOP853's dense output) is the
    reference the study uses instead."""

    kind: str
    times: int
    difference: float
    at_time: float
    bound: float
    passed: bool
    uncertainty: float = 0.0
    conditioning: float | None = None
    why: str = ""
    solution: object = None
    #: False where the check could not be run (the motion needs more DOP853 steps than its budget): the closed form
    #: is used unchecked, and the checks it would fail cannot decide (:func:`xcheck.study.checks.qualify`)
    checked: bool = True

    def to_json(self) -> dict:
        return {"kind": self.kind, "against": f"DOP853 (compiled) at rtol {GUARD_RTOL:g}", "times": self.times,
                "max_attitude_difference": _json(self.difference), "at_time": self.at_time, "bound": self.bound,
                "uncertainty": self.uncertainty, "conditioning": self.conditioning, "passed": self.passed,
                "checked": self.checked, "used": "exact" if self.passed else "dop853",
                **({"why": self.why} if self.why else {})}

    def describe(self) -> str:
        """The check in a sentence (the report's and the terminal's)."""
        against = f"DOP853 (compiled, rtol {GUARD_RTOL:g}) at {self.times} times of the study's grids"
        if not self.checked:
            return f"the {self.kind}, unchecked: {self.why}"
        if self.passed:
            text = f"the {self.kind}, checked against {against}: they agree to {self.difference:.1e} rad (bound {self.bound:.0e})"
            if self.uncertainty > GUARD_BOUND:
                text += (f"; this motion is sensitive (its last bit is worth {self.conditioning:.1e} rad): no reference "
                         f"in double precision is certain below {self.uncertainty:.1e} rad")
            return text
        return f"the {self.kind} was not used: {self.why}; the study's reference is {against.split(' at ')[0]}"


def _json(v):
    return float(v) if np.isfinite(v) else None


def guard_times(duration: float, grids=(), points: int = GUARD_POINTS) -> np.ndarray:
    """About ``points`` times [s] for the guard: the final time (where the final errors are measured) and times spread
    evenly over the points of the study's ``grids`` (steps [s]: each grid ``0, dt, 2 dt, ...``, its last point the
    duration), the coarsest first; without grids, evenly over the duration."""
    duration = float(duration)
    picks = [duration]
    for dt in sorted({float(g) for g in grids if 0 < g <= duration}, reverse=True)[:3]:
        n = int(np.floor(duration / dt + 1e-9))
        k = np.unique(np.linspace(1, n, max(1, points // 3)).round().astype(int))
        picks += list(np.minimum((k | 1) * dt, duration))  # odd multiples: not on a grid twice as coarse
    picks = np.unique(np.asarray(picks, dtype=float))
    if len(picks) < points:  # topped up evenly over the duration
        picks = np.unique(np.concatenate([picks, np.linspace(0, duration, points - len(picks) + 2)[1:-1]]))
    return picks


def check_exact(inertia, q0, omega0, duration: float, torque=None, times=None) -> ReferenceCheck:
    """The guard (issue 36): the exact reference of this body and torque (:func:`exact_reference`) at ``times``
    (default :func:`guard_times`) against the compiled DOP853 (:func:`xcheck.integrators.dop853.dop853_dense`),
    an independent integration of the same equations. Within :data:`GUARD_BOUND`, or within the check's own
    uncertainty where that is larger (DOP853's error, estimated from a second run, or the motion's conditioning:
    see :data:`CONDITIONING_ULPS`), the closed form is used; else, or where it cannot be computed, the study
    falls back to the DOP853 run, saying why (:class:`ReferenceCheck`)."""
    from .integrators.dop853 import dop853_at

    I, q0, omega0, _ = _inputs(inertia, q0, omega0, [0.0])
    times = guard_times(duration) if times is None else np.unique(np.asarray(times, dtype=float))
    kind = exact_kind(torque)

    def run(rtol, atol, inertia_=I, omega_=omega0):
        return dop853_at(inertia_, q0, omega_, duration, times, torque=torque, rtol=rtol, atol=atol,
                         max_steps=GUARD_MAX_STEPS)[0]

    def fallback(why, **found):
        return ReferenceCheck(kind, len(times), bound=found.pop("bound", GUARD_BOUND), passed=False, why=why,
                              solution=stand_in(I, q0, omega0, duration, torque, f"the {kind} was not used ({why})"),
                              **found)

    turned = float(np.linalg.norm(omega0)) * float(duration)
    if _DOP853_STEPS_PER_RAD * turned > GUARD_MAX_STEPS:  # used unchecked, saying so
        return ReferenceCheck(kind, 0, np.nan, 0.0, GUARD_BOUND, True, checked=False,
                              why=f"its independent check (DOP853) would need about {_DOP853_STEPS_PER_RAD * turned:.3g} "
                                  f"steps for |omega0| T = {turned:.3g} rad, beyond its budget of {GUARD_MAX_STEPS}")
    try:
        q_check = run(GUARD_RTOL, GUARD_ATOL)
    except RuntimeError as exc:
        raise ReferenceFailure(f"the independent check of the {kind} (DOP853) could not be run: {exc}") from None
    try:
        q_exact, _ = exact_reference(I, q0, omega0, times, torque)
    except ReferenceFailure as exc:
        return fallback(str(exc), difference=np.inf, at_time=0.0)
    errors = rot.attitude_error(q_exact, q_check)
    errors = np.where(np.isfinite(errors), errors, np.inf)
    worst = int(np.argmax(errors))
    difference, at_time = float(errors[worst]), float(times[worst])
    if difference <= GUARD_BOUND:
        return ReferenceCheck(kind, len(times), difference, at_time, GUARD_BOUND, True)
    spread = float(np.max(rot.attitude_error(q_check, run(SPREAD_RTOL, SPREAD_ATOL))))
    conditioning = np.finfo(float).eps * _sensitivity(run, I, omega0)
    uncertainty = max(SPREAD_FACTOR * spread, CONDITIONING_ULPS * conditioning)
    bound = max(GUARD_BOUND, uncertainty)
    found = dict(difference=difference, at_time=at_time, bound=float(bound), uncertainty=float(uncertainty),
                 conditioning=float(conditioning))
    if difference <= bound:
        return ReferenceCheck(kind, len(times), passed=True, **found)
    return fallback(f"it is {difference:.2g} rad from DOP853 at t = {at_time:.6g} s, beyond the bound {bound:.1e} rad "
                    "(the check's own uncertainty included)", **found)


def stand_in(inertia, q0, omega0, duration: float, torque, why: str):
    """The reference that stands in for a closed form the guard refused (``why``): the compiled DOP853 at the guard's
    own tolerances, its dense output kept (:class:`ReferenceFailure` where it cannot be run)."""
    from .integrators.dop853 import dop853_dense

    try:
        return dop853_dense(inertia, q0, omega0, duration, torque=torque, rtol=GUARD_RTOL, atol=GUARD_ATOL,
                            max_steps=GUARD_MAX_STEPS)
    except RuntimeError as exc:
        raise ReferenceFailure(f"{why}, and DOP853 could not stand in: {exc}") from None


def _sensitivity(run, inertia, omega0) -> float:
    """The largest change of the attitude [rad] over ``times`` per unit relative change of a principal moment (relative
    to the tensor's norm) or a body-rate component (relative to its norm): DOP853 runs at rtol 1e-12 with each
    perturbed by :data:`CONDITIONING_STEP` (smaller where the change leaves the linear range)."""
    moments, V = principal_axes(inertia)
    scale_I, scale_w = float(np.linalg.norm(inertia)), max(float(np.linalg.norm(omega0)), 1e-300)
    base = run(1e-12, 1e-14)
    worst = 0.0
    for i in range(6):
        step = CONDITIONING_STEP
        for _ in range(3):
            axis = V[:, i % 3]
            if i < 3:
                q = run(1e-12, 1e-14, inertia_=inertia + step * scale_I * np.outer(axis, axis))
            else:
                q = run(1e-12, 1e-14, omega_=omega0 + step * scale_w * axis)
            change = float(np.max(rot.attitude_error(q, base)))
            if change < 1e-3:  # still linear
                break
            step *= 1e-4 / change
        worst = max(worst, change / step)
    return worst
