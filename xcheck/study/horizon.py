"""The horizon study (issue 41): how far off a method is after an orbit, an hour, a day, and how its error grows. Each
method runs at a few steps over the long duration; its attitude error against the scenario's reference and its
energy drift (where the motion keeps an energy: torque free, or a top under its own gravity) are sampled on a
logarithmic time grid; each growth is fitted as a power of time, and the time within which the error stays under
1e-6 and 1e-3 rad is read off both grids together (a uniform one of :data:`UNIFORM_SAMPLES` times: its resolution).

The laws, as the theory has them: a Runge-Kutta method's attitude error grows as ``t`` at first and then as ``t^2``
once its phase error dominates, its energy drifts secularly (as ``t``); a symplectic method's energy error stays
bounded (``t^0``), though its phase drifts too (``lie-lgvi``)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..invariants import LABELS, change_text, invariant_series, largest_change
from ..rotations import attitude_error
from ..runners import RUNNERS
from ..scenario import Scenario

__all__ = ["HorizonLine", "HorizonResult", "run_horizon", "horizon_methods", "horizon_plan", "ENGINE_STEPS",
           "default_duration", "default_steps", "within_text", "DEFAULT_STEP_COUNT",
           "growth_exponent", "change_texts", "momentum_heading", "time_within", "log_indices", "THRESHOLDS",
           "LOG_SAMPLES", "UNIFORM_SAMPLES"]

#: The attitude errors [rad] whose first crossing a horizon study reports.
THRESHOLDS = (1e-6, 1e-3)
#: Times on the logarithmic grid (the figure's and the growth fits'), and on the uniform grid (the crossing times').
LOG_SAMPLES, UNIFORM_SAMPLES = 48, 2000
#: Errors below this [rad] are round-off for the growth fits (a method at round-off has no growth law to show).
ROUND_OFF = 1e-13
#: The compiled DOP853's tolerance for a horizon's reference (absolute: a hundredth of it), and the run at half of it
#: that checks it: a day of RAX-1 in the orbit field agrees with it to 1.7e-10 rad, 0.3 s a run (rtol 1e-13, a
#: study's, is 7e-8 rad off over the day).
HORIZON_RTOL = 2.5e-15
#: The most [rad] the reference may differ from itself at half the tolerance before a horizon study refuses to judge
#: by it: the errors it reads go down to 1e-6 rad (a day of RAX-1 with its momentum wheel and the gravity gradient
#: differs by 3.1 rad: that motion is too sensitive to be referenced over a day).
REFERENCE_LIMIT = 1e-8
#: The steps an engine's method takes in a horizon study at most, summed over its steps coarse to fine (its finer
#: steps beyond are left out, and the study says so): the engines other than MuJoCo cost 1-40 us a step where ours
#: cost 0.1-2, and an hour of the gyroscope at 1/64 s is 230 000 steps. Its coarsest step alone may exceed it: then
#: the method is left out.
ENGINE_STEPS = 300_000


@dataclass
class HorizonLine:
    """One method at one step over the horizon: the sampled times, attitude errors and energy drifts (None where the
    motion keeps no energy), the fitted growths, and the time within which the error stays under each of
    :data:`THRESHOLDS` (the whole duration where it never crosses; 0 where the first sample already does)."""

    method: str
    dt: float
    status: str
    message: str = ""
    t: list = field(default_factory=list)
    attitude_error: list = field(default_factory=list)
    growth: float | None = None
    #: the invariants at the sampled times (:mod:`xcheck.invariants`), each None where the motion does not keep it:
    #: the energy's and |L|'s signed relative changes (positive: gained, negative: damped; a top's: its energy with
    #: the potential, and its L's component about the vertical) and the angle [rad] L's direction turned; each with
    #: its law and direction ("gains ∝ t", "damps ∝ t^1.50", "bounded oscillation", "round-off") and, where it grows
    #: or stays bounded, the exponent of its running maximum
    energy_change: list | None = None
    energy_law: str | None = None
    energy_exponent: float | None = None
    momentum_change: list | None = None
    momentum_law: str | None = None
    #: what ``momentum_change`` is: "|L|", or "L·ĝ" (a top's component about the vertical, its direction not kept)
    momentum_label: str = "|L|"
    momentum_turn: list | None = None
    turn_law: str | None = None
    within: dict = field(default_factory=dict)
    final_error: float | None = None

    def to_json(self) -> dict:
        return dataclasses.asdict(self) | {"within": {f"{k:g}": v for k, v in self.within.items()}}

    def change_texts(self) -> tuple[str, str, str]:
        """The energy's, |L|'s and L's direction's largest changes with their laws, in words (``—``: not kept)."""
        return change_texts(self.to_json())


def momentum_heading(lines: list[dict]) -> str:
    """The |L| column's heading for lines (their JSON): "|L|", "L·ĝ" (tops), or both."""
    return " or ".join(dict.fromkeys(line.get("momentum_label", "|L|") for line in lines
                                     if line["status"] == "ok")) or "|L|"


def change_texts(line: dict) -> tuple[str, str, str]:
    """:meth:`HorizonLine.change_texts` of a line's JSON (the report reads the JSON)."""
    return (change_text(largest_change(line["energy_change"]), line["energy_law"]),
            change_text(largest_change(line["momentum_change"]), line["momentum_law"]),
            change_text(largest_change(line["momentum_turn"]), line["turn_law"], angle=True))


@dataclass
class HorizonResult:
    scenario: Scenario
    duration: float
    steps: tuple
    lines: list
    #: what the reference is over the horizon, and how it was checked
    reference_note: str = ""
    #: what was left out and why, one line for the methods left out for one reason (:func:`horizon_plan`)
    left_out: list = field(default_factory=list)

    def to_json(self) -> dict:
        from ..versions import versions

        return {"schema": "xcheck.horizon/2", "scenario": self.scenario.name, "duration": self.duration,
                "steps": list(self.steps), "reference": self.scenario.reference, "reference_note": self.reference_note,
                "versions": versions(), "lines": [line.to_json() for line in self.lines], "left_out": self.left_out}


def log_indices(n: int, count: int = LOG_SAMPLES) -> np.ndarray:
    """Indices of a run's ``n + 1`` samples, logarithmically spaced from the first step to the last (each once)."""
    return np.unique(np.rint(np.geomspace(1, max(n, 1), count)).astype(np.int64))


def _fit(t, y, floor: float) -> float | None:
    """The exponent of ``y ∝ t^p`` over the samples above ``floor`` in the last two decades of ``t`` (None with fewer
    than four)."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    keep = (t >= t[-1] / 100) & (y > floor) & np.isfinite(y)
    if keep.sum() < 4:
        return None
    return float(np.polyfit(np.log(t[keep]), np.log(y[keep]), 1)[0])


def growth_exponent(t, error) -> float | None:
    """``p`` in attitude error ∝ t^p, fitted over the last two decades of time above round-off (:data:`ROUND_OFF`)."""
    return _fit(t, error, ROUND_OFF)


def time_within(t, error, bound: float) -> float:
    """The last time before the error first exceeds ``bound`` (``t[-1]`` where it never does, 0 at once)."""
    over = np.nonzero(np.asarray(error) > bound)[0]
    if not len(over):
        return float(t[-1])
    return 0.0 if over[0] == 0 else float(t[over[0] - 1])


#: The steps of a horizon study when none are given: the scenario's three coarsest quick steps.
DEFAULT_STEP_COUNT = 3


def default_duration(scenario: Scenario) -> float:
    """A horizon's duration when none is given: the scenario's ``[horizon]`` duration, else 100 times its own."""
    return scenario.horizon[0] if scenario.horizon else 100.0 * scenario.duration


def default_steps(scenario: Scenario, duration: float) -> list[float]:
    """A horizon's steps when none are given: the ``[horizon]`` steps, else the scenario's :data:`DEFAULT_STEP_COUNT`
    coarsest quick steps within ``duration``."""
    if scenario.horizon and scenario.horizon[1]:
        return list(scenario.horizon[1])
    return [s for s in sorted(scenario.quick_steps, reverse=True) if s <= duration][:DEFAULT_STEP_COUNT]


def within_text(value: float, duration: float) -> str:
    """A time within a bound, as read: the whole run, 'at once', or seconds (the terminal's and the report's)."""
    if value >= duration:
        return "whole run"
    return "at once" if value == 0 else f"{value:.4g} s"


def horizon_methods() -> list:
    """The methods a horizon study runs by default: every fixed-step method installed here, ours, MuJoCo's and the
    engines' (not the printed algorithm 172, a demonstration; not an opt-in engine's, MJX's)."""
    return [m for m, r in RUNNERS.items() if not r.adaptive and r.demonstration is None and not r.opt_in]


def horizon_plan(scenario: Scenario, methods, steps, duration: float) -> tuple[list, list]:
    """``([(method, dt)] to run, [lines saying what was left out and why])``: every method at every step, but a method
    that cannot represent the body (:attr:`~xcheck.runners.Runner.cannot`), a step an engine's clock cannot take, and
    an engine's steps beyond :data:`ENGINE_STEPS` are left out, said."""
    from ..trajectory import step_plan

    plan, left = [], []
    over: dict = {}
    for method in methods:
        runner = RUNNERS[method]
        why = runner.cannot_run(scenario.model)
        if why:
            left.append(f"{method} not run: {why}")
            continue
        total = 0
        for dt in steps:
            if runner.clock is not None:
                try:
                    runner.clock(dt)
                except ValueError as exc:
                    left.append(f"{method} not run at {dt:g} s: {exc}")
                    continue
            total += step_plan(dt, duration)[0]
            if runner.engine not in ("xcheck", "mujoco") and total > ENGINE_STEPS:
                over.setdefault(method, []).append(dt)
                continue
            plan.append((method, dt))
    groups: dict = {}
    for method, dts in over.items():
        groups.setdefault(tuple(dts), []).append(method)
    for dts, names in groups.items():
        left.append(f"{', '.join(names)} not run at {', '.join(f'{d:g}' for d in dts)} s: the step budget of "
                    f"{ENGINE_STEPS:,} steps a method of an engine that takes microseconds a step where ours take a "
                    "tenth of one")
    return plan, left


def _reference(long: Scenario, ctx, duration: float):
    """``(reference, what it is)`` over the horizon: the closed form at any time, the compiled DOP853 checked against
    itself (:class:`_Compiled`), or the scenario's own; :class:`~xcheck.reference.ReferenceFailure` where it cannot
    cover the duration."""
    from .context import scenario_reference

    if long.reference == "exact":  # the closed form at any time (its guard against DOP853 is the ordinary study's,
        # over the scenario's own duration: its phase at large times is tested)
        return _Exact(ctx), "the closed form, evaluated at each time (its phase: the rounding of |w| t)"
    if long.reference == "dop853":
        ref = _Compiled(ctx, duration)
        return ref, ref.note
    from ..reference import ReferenceFailure

    try:
        return scenario_reference(long), f"the scenario's {long.reference} reference"
    except ReferenceFailure as exc:
        raise ReferenceFailure(f"the scenario's {long.reference} reference over {duration:g} s: {exc}") from None


def horizon_lines(long: Scenario, plan, progress=None, ref=None) -> list:
    """The :class:`HorizonLine` of each ``(method, dt)`` of ``plan`` over ``long``'s duration (a worker's part: its own
    context and reference, unless ``ref`` is given)."""
    from .context import run_context

    ctx = run_context(long)
    if ref is None:
        ref = _reference(long, ctx, long.duration)[0]
    lines = []
    for k, (method, dt) in enumerate(plan):
        if progress:
            progress(k, len(plan), f"{method} at {dt:g} s")
        lines.append(_line(RUNNERS[method], ctx, ref, dt))
    return lines


def run_horizon(scenario: Scenario, *, duration: float, steps, methods=None, progress=None,
                pool=None) -> HorizonResult:
    """Every method of ``methods`` (default: :func:`horizon_methods`) at each of ``steps`` over ``duration`` s, against
    the scenario's reference over that duration (:class:`HorizonLine` each; what :func:`horizon_plan` leaves out,
    said). ``pool``: a process pool whose worker runs every other run of the plan while this process runs the rest."""
    from .context import run_context

    long = dataclasses.replace(scenario, duration=float(duration))
    ref, note = _reference(long, run_context(long), float(duration))
    if methods is None:
        methods = horizon_methods()
    plan, left = horizon_plan(long, methods, [float(s) for s in steps], float(duration))
    if pool is None:
        lines = horizon_lines(long, plan, progress, ref)
    else:  # every other run to the worker (the plan's costs vary along it: methods, then steps)
        there = pool.submit(horizon_lines, long, plan[1::2])
        here = horizon_lines(long, plan[0::2], progress and (lambda k, n, what: progress(2 * k, len(plan), what)), ref)
        if progress:
            progress(len(here) + len(plan) // 2 - 1, len(plan), "the worker's runs")
        lines = [None] * len(plan)
        lines[0::2], lines[1::2] = here, there.result()
    if progress:
        progress(len(plan), len(plan), "")
    return HorizonResult(long, float(duration), tuple(float(s) for s in steps), lines, note, left)


class _Exact:
    """The scenario's closed form at any times: ``at(t) -> (q, omega, mask)`` as a study's reference."""

    def __init__(self, ctx):
        self.ctx = ctx

    def at(self, t):
        from ..reference import exact_reference

        q, w = exact_reference(self.ctx.inertia, self.ctx.q0, self.ctx.omega0, np.asarray(t), self.ctx.torque)
        return q, w, np.ones(len(t), bool)


class _Compiled:
    """The compiled DOP853 over the horizon at :data:`HORIZON_RTOL`, kept dense, checked at once against a run at
    half the tolerance on a grid of 200 times (``difference``, said in ``note``)."""

    def __init__(self, ctx, duration: float):
        from ..integrators.dop853 import dop853_at, dop853_dense
        from ..reference import ReferenceFailure

        args = (ctx.inertia, ctx.q0, ctx.omega0, duration)
        budget = 5_000_000
        try:
            self.sol = dop853_dense(*args, torque=ctx.torque, rtol=HORIZON_RTOL, atol=HORIZON_RTOL / 100,
                                    max_steps=budget)
            t = np.linspace(0.0, duration, 201)
            q_half, _ = dop853_at(*args, t, torque=ctx.torque, rtol=HORIZON_RTOL / 2, atol=HORIZON_RTOL / 200,
                                  max_steps=2 * budget)
        except RuntimeError as exc:
            raise ReferenceFailure(f"the compiled DOP853 over {duration:g} s: {exc}") from None
        self.difference = float(np.max(attitude_error(self.sol(t)[0], q_half)))
        if not self.difference <= REFERENCE_LIMIT:
            raise ReferenceFailure(
                f"the compiled DOP853 at rtol {HORIZON_RTOL:g} differs from itself at half the tolerance by "
                f"{self.difference:.2g} rad over {duration:g} s (at most {REFERENCE_LIMIT:g}): the motion is too "
                "sensitive to be referenced that far, and nothing would be judged by it")
        self.note = (f"the compiled DOP853 at rtol {HORIZON_RTOL:g} ({self.sol.steps:,} steps), within "
                     f"{self.difference:.2g} rad of itself at half the tolerance over the {duration:g} s")

    def at(self, t):
        q, w = self.sol(np.asarray(t))
        return q, w, np.ones(len(q), bool)


def _line(runner, ctx, ref, dt: float) -> HorizonLine:
    traj = runner.run(ctx, dt)
    if not traj.ok or len(traj.t) < 3:
        return HorizonLine(runner.name, dt, "failed", traj.message or "the run did not complete")
    n = len(traj.t) - 1
    uniform = np.unique(np.rint(np.linspace(0, n, UNIFORM_SAMPLES + 1)).astype(np.int64))
    logs = log_indices(n)
    idx = np.union1d(uniform, logs)
    q_ref, _, mask = ref.at(traj.t[idx])
    err = np.full(len(idx), np.nan)
    err[mask] = attitude_error(traj.q[idx][mask], q_ref[mask])
    on_log = np.isin(idx, logs)
    t_log, e_log = traj.t[idx][on_log], err[on_log]
    pick = np.concatenate([[0], idx[on_log]])  # the start: what every change is relative to
    kept = invariant_series(ctx.inertia, traj.q[pick], traj.omega[pick], ctx.torque, traj.t[pick])
    laws = kept.laws(traj.t[pick], n)

    def listed(series):  # at the logarithmic grid's times (the start left out)
        return None if series is None else series[1:].tolist()

    return HorizonLine(runner.name, dt, "ok", t=t_log.tolist(), attitude_error=e_log.tolist(),
                       growth=growth_exponent(t_log, e_log), energy_change=listed(kept.energy),
                       energy_law=laws["energy_law"], energy_exponent=laws["energy_exponent"],
                       momentum_change=listed(kept.momentum), momentum_law=laws["momentum_law"],
                       momentum_label="L·ĝ" if kept.momentum_label == LABELS["momentum·g"] else "|L|",
                       momentum_turn=listed(kept.turn), turn_law=laws["turn_law"],
                       within={b: time_within(traj.t[idx], err, b) for b in THRESHOLDS},
                       final_error=float(err[-1]))
