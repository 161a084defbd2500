"""Finer steps that decide an engine's order (issue 63): where a study leaves an engine's order check undecided
because its finest errors are still too large to show an order (a first-order engine on a thin rod, 1.8, 0.86,
0.42 rad off at 1/16384 … 1/65536 s), the study runs the next halvings of that method's finest step, as many as
its expected order says will bring three runs within :data:`~xcheck.study.WIDE_CEILING` and one more, where they
fit a budget of time measured on its own finest run; the order is then fitted on them all, and the study says
which steps it added (:attr:`xcheck.study.StudyResult.finer`)."""

from __future__ import annotations

from ..metrics import ORDER_CEILING, ladder_steps
from ..trajectory import check_step, step_plan

__all__ = ["finer_steps", "merged", "FINER_BUDGET", "FINER_MOST", "FINER_MOST_STEPS", "FINER_RUNS"]

#: What the finer runs of one study may cost in all [s], estimated from each method's finest run: a quick study,
#: a full one (measured: a thin rod's two finer MuJoCo Euler runs, 1/131072 and 1/262144 s over 1 s, 0.8 s; a
#: near-separatrix body's three, 1/2048 … 1/8192 s over 50 s, 1.4 s).
FINER_BUDGET = {True: 20.0, False: 120.0}
#: At most this many halvings past a method's finest step.
FINER_MOST = 4
#: A run of at most this many steps (its memory, :data:`~xcheck.trajectory.BYTES_PER_STEP` a step, is bounded too).
FINER_MOST_STEPS = 2 ** 20
#: Runs within :data:`~xcheck.study.WIDE_CEILING` an order is fitted on (two local orders that must agree).
FINER_RUNS = 3
#: The estimate's margin over the finest run's seconds a step.
_MARGIN = 1.5


def finer_steps(scenario, methods: dict, checks: list, over_budget: dict, quick: bool, ceiling: float) -> dict:
    """``method -> finer steps`` (coarse to fine) for each engine method whose order check is undecided with no
    order measured, its finest run completed but fewer than two of its errors within the small-error regime
    (:data:`~xcheck.metrics.ORDER_CEILING`): halvings of its finest ladder step, extrapolated at its expected order,
    until :data:`FINER_RUNS` runs are within ``ceiling`` [rad] and one more (at most :data:`FINER_MOST`), cheapest
    first while the study's estimated cost stays within :data:`FINER_BUDGET`. A method whose steps a budget cut
    (``over_budget``), one of ours, an adaptive one, or one a known finding explains is not extended."""
    offers = []
    for c in checks:
        m = methods.get(c.method)
        if not (c.kind == "order" and c.inconclusive and c.value is None and not c.known and m is not None
                and m.engine != "xcheck" and not m.adaptive and m.expected_order and c.method not in over_budget):
            continue
        ladder = set(ladder_steps([r.setting for r in m.runs], scenario.your_step))
        runs = [r for r in m.runs if r.setting in ladder]
        last = runs[-1] if runs else None
        if last is None or not last.ok or not last.attitude_error > 0 or last.substeps:
            continue
        errors = [r.attitude_error for r in runs if r.ok]
        if sum(e <= ORDER_CEILING for e in errors) >= 2:  # the small-error regime has its runs: more will not help
            continue
        plan = _halvings(last.dt, last.attitude_error, m.expected_order, sum(e <= ceiling for e in errors), ceiling,
                         scenario.duration)
        if plan:
            per_step = last.wall_time / step_plan(last.dt, scenario.duration)[0]
            cost = _MARGIN * per_step * sum(step_plan(d, scenario.duration)[0] for d in plan)
            offers.append((cost, c.method, plan))
    chosen, spent = {}, 0.0
    for cost, name, plan in sorted(offers):
        if spent + cost <= FINER_BUDGET[bool(quick)]:
            chosen[name], spent = plan, spent + cost
    return chosen


def _halvings(dt: float, error: float, order: int, within: int, ceiling: float, duration: float) -> tuple:
    """The halvings of ``dt`` (its run ``error`` [rad] off, ``within`` runs within ``ceiling``) that bring
    :data:`FINER_RUNS` within it, extrapolated at ``order``, and one more; () where they cannot all be run (over
    :data:`FINER_MOST` halvings, :data:`FINER_MOST_STEPS` steps or the memory here)."""
    plan = []
    while within < FINER_RUNS + 1:
        if len(plan) == FINER_MOST:
            return ()
        dt, error = dt / 2, error / 2 ** order
        try:
            if check_step(dt, duration) > FINER_MOST_STEPS:
                return ()
        except ValueError:  # its memory
            return ()
        plan.append(dt)
        within += error <= ceiling
    return tuple(plan)


def merged(results: list, finer: list) -> list:
    """``results`` (a study's :class:`~xcheck.results.MethodRuns`) with the runs of ``finer`` (the same methods'
    runs at their finer steps) appended to theirs; the figures' series and the partner comparisons stay the
    study's own."""
    from dataclasses import replace

    more = {r.method: r for r in finer if not r.import_error and not r.reference_error}
    return [replace(res, runs=[*res.runs, *more[res.method].runs]) if res.method in more else res for res in results]
