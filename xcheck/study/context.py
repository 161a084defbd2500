"""What a worker keeps per scenario (one process runs several methods of it): the run context (the body, its
torque, the initial state) and the reference, both cached per process, a reference that failed included."""

from __future__ import annotations

import numpy as np

from ..guard import check_exact, guard_times, stand_in
from ..motion import (
    cone_of,
    crossings,
    flip_summary,
    intermediate_rate,
    nutation_level,
    precession_summary,
    refined_crossings,
    top_frame,
    tumbles,
)
from ..reference import ReferenceFailure, dop853_solution, exact_reference, own_period
from ..runners import RUNNERS, RunContext
from ..scenario import Scenario

__all__ = ["run_context", "scenario_reference", "scenario_key"]

_CACHE: dict = {}


def scenario_key(scenario: Scenario):
    return (str(scenario.path), scenario.name, str(scenario.model), scenario.duration, tuple(scenario.q0),
            tuple(scenario.omega0), scenario.sequence, repr(scenario.torque), scenario.reference,
            scenario.reference_method, scenario.reference_dt, scenario.inertia, scenario.wheel_speeds)


def _cached(kind, scenario, make):
    """Per-process cache of a scenario's run context and reference (a worker runs several methods); a
    :class:`ReferenceFailure` is cached too, so that a reference over budget is tried once per process."""
    key = (kind, scenario_key(scenario))
    if key not in _CACHE:
        if len(_CACHE) > 16:
            _CACHE.clear()
        try:
            _CACHE[key] = make()
        except ReferenceFailure as exc:
            _CACHE[key] = exc
    if isinstance(_CACHE[key], ReferenceFailure):
        raise _CACHE[key]
    return _CACHE[key]


def run_context(scenario: Scenario) -> RunContext:
    """The scenario's body, torque and initial state (:func:`xcheck.assembly.context_of`), once per process."""
    from ..assembly import context_of

    return _cached("context", scenario, lambda: context_of(scenario))


class _Reference:
    """The reference of a scenario, evaluated on any run's grid (cached per process). An exact one is checked first
    (the guard, :func:`~xcheck.guard.check_exact`: against the compiled DOP853 at times of the study's own
    grids); where it fails, the study's reference is that DOP853 run instead (``used`` says which), and ``check``
    (its JSON) says why."""

    def __init__(self, scenario: Scenario, ctx: RunContext):
        self.kind = self.used = scenario.reference
        self.scenario, self.ctx = scenario, ctx
        self.check = None
        self._grids = []
        if self.kind == "exact" and scenario.guarded and scenario.guarded[0] == scenario_key(scenario):
            self.check = scenario.guarded[1]  # checked where the study was planned
            if self.check["used"] == "dop853":
                self.used = "dop853"
                self.dense = stand_in(ctx.inertia, ctx.q0, ctx.omega0, ctx.duration, ctx.torque, self.check["text"])
        elif self.kind == "exact":
            grids = (*scenario.steps, *scenario.quick_steps, scenario.adaptive_step)
            check = check_exact(ctx.inertia, ctx.q0, ctx.omega0, ctx.duration, ctx.torque,
                                guard_times(ctx.duration, grids))
            self.check = check.to_json() | {"text": check.describe()}
            if not check.passed:
                self.used, self.dense = "dop853", check.solution
        elif self.kind == "dop853":
            self.dense = dop853_solution(ctx.inertia, ctx.q0, ctx.omega0, ctx.duration, torque=ctx.torque)
        elif self.kind == "fine":
            runner = RUNNERS[scenario.reference_method]
            self.fine = runner.run(ctx, scenario.reference_dt)
            if not self.fine.ok:
                raise ReferenceFailure(f"the fine reference ({scenario.reference_method} at {scenario.reference_dt:g} "
                                       f"s) did not complete: {self.fine.message}")

    def at(self, t):
        """(q, omega, mask): reference values at the times ``t`` where it is defined (``mask``). The last few
        grids asked for are kept: every method of a scenario runs on the same grids, and a worker runs several."""
        t = np.asarray(t, dtype=float)
        for grid, values in self._grids:
            if len(grid) == len(t) and np.array_equal(grid, t):
                return values
        values = self._at(t)
        self._grids = [(t.copy(), values), *self._grids[:15]]
        return values

    def _grid(self):
        """The times the motion's numbers sample the reference at: 64 a period of the motion
        (:func:`xcheck.reference.own_period`), at least 8193 over the run, at most 2e6."""
        ctx = self.ctx
        period = own_period(ctx.inertia, ctx.q0, ctx.omega0, ctx.torque) or ctx.duration
        return np.linspace(0.0, ctx.duration, int(min(max(8192, 64 * ctx.duration / period), 2e6)) + 1)

    def flips(self):
        """The reference's own flips where the body tumbles (:mod:`xcheck.motion`: each sign change of the rate
        about the intermediate axis bisected on the reference itself, a fine run's on its grid), None elsewhere or
        where it never flips; computed once."""
        if not hasattr(self, "_flips"):
            self._flips = None
            ctx = self.ctx
            if tumbles(ctx.inertia, ctx.omega0):
                if self.used == "fine":
                    times = crossings(self.fine.t, intermediate_rate(ctx.inertia, self.fine.omega))
                else:
                    times = refined_crossings(lambda t: intermediate_rate(ctx.inertia, self._at(t)[1]), self._grid())
                self._flips = flip_summary(times) if len(times) else None
        return self._flips

    def precession(self):
        """A top's or an axisymmetric body's cone (:mod:`xcheck.motion`): ``{"frame": (axis, pole), "level": the
        middle of the axis' height or None, "reference": its precession_summary}`` on the reference sampled 64 times
        a period of the motion (a fine run on its grid), None for any other body; computed once."""
        if not hasattr(self, "_precession"):
            self._precession = None
            ctx = self.ctx
            frame = top_frame(ctx.inertia, ctx.q0, ctx.omega0, ctx.torque)
            if frame is not None:
                if self.used == "fine":
                    t, q = self.fine.t, self.fine.q
                else:
                    t = self._grid()
                    q = self._at(t)[0]
                u, azimuth = cone_of(q, *frame)
                level = nutation_level(u)
                self._precession = {"frame": frame, "level": level,
                                    "reference": precession_summary(t, u, azimuth, level)}
        return self._precession

    def _at(self, t):
        if self.used == "exact":
            q, w = exact_reference(self.ctx.inertia, self.ctx.q0, self.ctx.omega0, t, self.ctx.torque)
            return q, w, np.ones(len(t), bool)
        if self.used == "dop853":
            q, w = self.dense(t)
            return q, w, np.ones(len(t), bool)
        # fine: only at times on its own grid (its last point is the duration, whatever the step)
        dt, last = self.scenario.reference_dt, len(self.fine.t) - 1
        at_end = np.abs(t - self.fine.t[-1]) <= 1e-12
        idx = np.where(at_end, last, np.clip(np.rint(t / dt).astype(np.int64), 0, last))
        on_grid = at_end | (np.abs(idx * dt - t) <= 1e-9 * np.maximum(1.0, t))
        return self.fine.q[idx], self.fine.omega[idx], on_grid


def scenario_reference(scenario: Scenario) -> _Reference:
    return _cached("reference", scenario, lambda: _Reference(scenario, run_context(scenario)))
