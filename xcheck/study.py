"""Convergence studies: every method x every step of a scenario against its reference, in worker
processes (deterministic: each run is independent), producing results of schema ``xcheck.convergence/1``
plus the sampled series the report plots."""

from __future__ import annotations

import dataclasses
import math
import time
from concurrent.futures import FIRST_COMPLETED, as_completed, wait
from dataclasses import dataclass, field

import numpy as np

from . import rotations as rot
from .engines import ENGINES
from .metrics import (ORDER_FLOOR, TOLERANCES, StepWithin, errors_against, invariant_drift, largest_step_within,
                      observed_order, tolerance_key)
from .pool import ready_workers, worker_pool
from .reference import ReferenceFailure, dop853_solution, exact_torque_free
from .results import Check, MethodResult, Run
from .runners import RUNNERS, RunContext
from .scenario import Scenario, build_torque, check_steps
from .trajectory import step_label, step_plan
from .versions import versions

__all__ = ["run_study", "run_studies", "StudyResult", "PLOT_SAMPLE_DT", "throughput_rows", "planned_checks"]

SCHEMA = "xcheck.convergence/1"
#: Series kept for plots and CSV are sampled at this spacing [s] (or every step, if coarser).
PLOT_SAMPLE_DT = 1 / 256


@dataclass
class StudyResult:
    """A study's findings, typed (:mod:`xcheck.results`): the scenario, its steps (coarse to fine), every
    method's result, the checks; ``series``: per method, the sampled finest good run (``t``, ``q``, ``omega``,
    ``attitude_error``, ``energy``, ``momentum``, ``euler``) and the reference on the same times, for plots and
    CSV. :attr:`data` is the JSON (schema ``xcheck.convergence/1``)."""

    scenario: Scenario
    steps: list
    methods: dict  # name -> MethodResult
    checks: list  # of Check
    order_floor: float
    quick: bool = False
    series: dict = field(default_factory=dict)
    comparisons: list = field(default_factory=list)  # {"a", "b", "dt", "max_attitude_difference"}
    versions: dict = field(default_factory=versions)

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def data(self) -> dict:
        sc = self.scenario
        return {"schema": SCHEMA, "scenario": sc.name, "description": sc.description, "model": str(sc.model),
                "duration": sc.duration, "reference": sc.reference, "torque": sc.torque,
                "initial": {"quaternion": sc.q0.tolist(), "angular_velocity": sc.omega0.tolist(),
                            "euler_sequence": sc.sequence},
                "quick": self.quick, "steps": list(self.steps), "order_floor": self.order_floor,
                "versions": self.versions, "methods": {n: m.to_json() for n, m in self.methods.items()},
                "checks": [c.to_json() for c in self.checks], "passed": self.passed,
                "comparisons": list(self.comparisons)}


def default_methods(scenario: Scenario) -> list[str]:
    return list(scenario.methods) if scenario.methods else list(RUNNERS)


def comparison_partner(scenario: Scenario, method: str, methods) -> str | None:
    """Which of our methods an engine's method is compared with directly, trajectory against trajectory at
    the same step (no reference needed): its twin (the same scheme: MuJoCo's RK4 and ``lie-rkmk4``, Basilisk's
    and ``mrp-rk4``) when the study has it, else one of the same order, the scenario's ``reference_method`` first,
    then ``lie-rkmk4``; for an engine method of an order none of ours has (MuJoCo's first-order ones), our
    highest-order method, so that the difference measures the engine's own error. None for our methods, or
    when the study has none of ours to compare with."""
    runner = RUNNERS[method]
    if runner.engine == "xcheck" or runner.adaptive:  # an adaptive method's runs share one output step
        return None
    ours = [m for m in methods if RUNNERS[m].engine == "xcheck" and RUNNERS[m].expected_order is not None
            and m not in scenario.checks.get("expected_to_fail", ())]
    if not ours:
        return None
    if runner.twin in ours:  # the same scheme as the engine's: their difference is the engine's own
        return runner.twin
    preferred = sorted(ours, key=lambda m: (m != scenario.reference_method, m != "lie-rkmk4"))
    same = [m for m in preferred if RUNNERS[m].expected_order == runner.expected_order]
    return same[0] if same else max(preferred, key=lambda m: RUNNERS[m].expected_order)


def run_study(scenario: Scenario, *, methods=None, steps=None, quick: bool = False, workers: int | None = None,
              progress=None, pool=None, timing: bool = True, here: bool = False) -> StudyResult:
    """Run the convergence study of ``scenario``.

    ``methods``/``steps`` override the scenario's; ``quick`` uses its ``quick_steps`` (and an adaptive method
    its ``quick_tolerances``). ``workers`` processes (default: the CPU count; 1 runs in this process).
    ``progress(done, total, label)`` is called as runs finish. ``pool`` reuses an existing executor (the report
    runs all scenarios in one).
    """
    methods = list(methods) if methods else default_methods(scenario)
    steps_given = steps is not None
    for m in methods:
        if m not in RUNNERS:
            raise ValueError(f"methods: unknown {m!r}; expected one of {', '.join(RUNNERS)}")
    steps = sorted((float(s) for s in (steps or (scenario.quick_steps if quick else scenario.steps))), reverse=True)
    try:
        check_steps(steps, scenario.duration)
    except ValueError as exc:
        raise ValueError(f"steps: {exc}") from None
    tolerances = scenario.quick_tolerances if quick else scenario.tolerances
    tasks = [(scenario, m, tuple(steps), comparison_partner(scenario, m, methods), tolerances, timing) for m in methods]
    results = _map(_run_method, tasks, workers=workers, progress=progress, pool=pool,
                   labels=[f"{scenario.name}: {m}" for m in methods], here=_prefer_here if here else None)
    return assemble(scenario, steps, results, quick=quick and not steps_given)


def run_studies(scenarios, *, quick: bool = False, workers: int | None = None, progress=None,
                pool=None, on_study=None, here: bool = False) -> list[StudyResult]:
    """Several studies over one pool of worker processes: every (scenario, method) pair is one task,
    submitted together so that both cores stay busy to the end. ``on_study(study)`` is called as soon as a
    scenario's last task is in (the report submits its figures then, behind the studies still queued). ``here``:
    this process runs tasks too, beside ``pool``."""
    plans = []
    for sc in scenarios:
        methods = default_methods(sc)
        steps = sorted((float(s) for s in (sc.quick_steps if quick else sc.steps)), reverse=True)
        plans.append((sc, methods, steps))
    tasks = [(sc, m, tuple(steps), comparison_partner(sc, m, methods), sc.quick_tolerances if quick else sc.tolerances)
             for sc, methods, steps in plans for m in methods]
    labels = [f"{sc.name}: {m}" for sc, methods, _ in plans for m in methods]
    owner = [k for k, (_, methods, _) in enumerate(plans) for _ in methods]
    first = np.cumsum([0] + [len(methods) for _, methods, _ in plans])
    missing = [len(methods) for _, methods, _ in plans]
    studies: list = [None] * len(plans)
    results: list = [None] * len(tasks)

    def done(i, result):
        results[i] = result
        k = owner[i]
        missing[k] -= 1
        if missing[k] == 0:
            sc, _, steps = plans[k]
            studies[k] = assemble(sc, steps, results[first[k]:first[k + 1]], quick=quick)
            if on_study:
                on_study(studies[k])

    _map(_run_method, tasks, workers=workers, progress=progress, pool=pool, labels=labels, on_result=done,
         here=_prefer_here if here else None)
    return studies


def _prefer_here(task) -> bool:
    """The tasks this process takes first when it works beside a pool: not those of an engine whose import
    is costly (:attr:`xcheck.engines.Engine.to_workers`: the workers import it as they start)."""
    engine = ENGINES.get(RUNNERS[task[1]].engine)  # None: ours
    return engine is None or not engine.to_workers


def _map(fn, tasks, *, workers, progress, pool, labels, on_result=None, here=None):
    """``fn(*task)`` for every task, in ``pool`` (or a pool of its own, or this process for ``workers=1``), calling
    ``record`` as each finishes. ``here``: this process works too, beside the pool (see :func:`_map_here`); a
    predicate that says which tasks it prefers (None: it only waits)."""
    total = len(tasks)
    out = [None] * total
    count = [0]

    def record(i, result):
        out[i] = result
        count[0] += 1
        if on_result:
            on_result(i, result)
        if progress:
            progress(count[0], total, labels[i])

    if pool is None and (workers == 1 or total == 1):
        for i, task in enumerate(tasks):
            record(i, fn(*task))
        return out
    if pool is None:
        with worker_pool(workers) as own:
            return _map(fn, tasks, workers=workers, progress=progress, pool=own, labels=labels, on_result=on_result,
                        here=here)
    if here is not None:
        _map_here(fn, tasks, pool, record, here)
        return out
    futures = {pool.submit(fn, *task): i for i, task in enumerate(tasks)}
    for fut in as_completed(futures):
        record(futures[fut], fut.result())
    return out


def _map_here(fn, tasks, pool, record, prefer) -> None:
    """Share ``tasks`` between ``pool`` and this process. The pool takes them from the front of a queue in which
    the tasks this process would rather not run come first (``prefer(task)`` False: those of an engine the
    workers import as they start), kept one task ahead of its workers so that what else is submitted to it, a
    scenario's figures, is not queued behind every study, and given none before one of them has started (a task
    waiting for a worker's imports is better run here); this process takes them from the back, collecting
    finished results between its own, and the workers' own too when more are left than the workers take next.
    Every process pays its imports and compiled-code loading once (1-3 s): a worker fewer, and this process
    working, is that much less to pay."""
    pending = sorted(range(len(tasks)), key=lambda i: bool(prefer(tasks[i])))  # stable: the given order within
    futures: dict = {}

    def collect(block: bool):
        if block and futures:
            wait(list(futures), return_when=FIRST_COMPLETED)
        for fut in [f for f in futures if f.done()]:
            record(futures.pop(fut), fut.result())

    workers = getattr(pool, "_max_workers", 1) or 1
    while pending or futures:
        ready = ready_workers(pool)
        # the workers' own tasks wait for them however long they take to start; another task goes to a worker
        # only once one has started (this process would otherwise wait for it)
        while pending and len(futures) < workers + 1 and (ready or not prefer(tasks[pending[0]])):
            i = pending.pop(0)
            futures[pool.submit(fn, *tasks[i])] = i
        collect(block=False)
        if not pending:
            collect(block=True)
            continue
        if not prefer(tasks[pending[-1]]) and futures and len(pending) <= workers:
            collect(block=True)  # the workers' own, and no more than they take next: wait for them
            continue
        i = pending.pop()
        record(i, fn(*tasks[i]))


# ------------------------------------------------------------------------------------------------
# in a worker
# ------------------------------------------------------------------------------------------------
_CACHE: dict = {}
_PARTNER_RUNS: dict = {}  # (scenario key, partner, dt) -> Trajectory | None (see _difference)


def _key(scenario: Scenario):
    return (str(scenario.path), scenario.name, str(scenario.model), scenario.duration, tuple(scenario.q0),
            tuple(scenario.omega0), scenario.sequence, repr(scenario.torque), scenario.reference,
            scenario.reference_method, scenario.reference_dt, scenario.inertia)


def _cached(kind, scenario, make):
    """Per-process cache of a scenario's run context and reference (a worker runs several methods); a
    :class:`ReferenceFailure` is cached too, so that a reference over budget is tried once per process."""
    key = (kind, _key(scenario))
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
    def make():
        from .models import load_body

        body = load_body(scenario.model)
        moments = scenario.inertia
        return RunContext(inertia=body.inertia if moments is None else body.inertia_with(moments),
                          model_path=str(scenario.model), q0=scenario.q0, omega0=scenario.omega0,
                          duration=scenario.duration, torque=build_torque(scenario, body), sequence=scenario.sequence,
                          model_moments=None if moments is None else tuple(moments))
    return _cached("context", scenario, make)


class _Reference:
    """The reference of a scenario, evaluated on any run's grid (cached per process)."""

    def __init__(self, scenario: Scenario, ctx: RunContext):
        self.kind = scenario.reference
        self.scenario, self.ctx = scenario, ctx
        self._grids = []
        if self.kind == "exact":  # fails early when the body turns too fast for the quadrature
            exact_torque_free(ctx.inertia, ctx.q0, ctx.omega0, np.array([0.0, ctx.duration]))
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

    def _at(self, t):
        if self.kind == "exact":
            q, w = exact_torque_free(self.ctx.inertia, self.ctx.q0, self.ctx.omega0, t)
            return q, w, np.ones(len(t), bool)
        if self.kind == "dop853":
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


def _run_method(scenario: Scenario, method: str, steps: tuple, partner: str | None = None,
                tolerances: tuple | None = None, timing: bool = True) -> dict:
    """All steps of one method (in a worker): per-run metrics, the sampled finest good run, and with a
    ``partner`` (:func:`comparison_partner`) the largest attitude difference between the two at every step."""
    import warnings

    warnings.filterwarnings("ignore", category=UserWarning, module="xcheck.models")
    try:
        return measure_method(scenario, method, steps, partner, tolerances=tolerances, timing=timing)
    except ReferenceFailure as exc:  # building or evaluating it: nothing can be measured, the study fails with
        return {"method": method, "runs": [Run.failed(dt, "failed", f"no reference: {exc}", 0.0, rtol)  # the reason
                                           for dt, rtol in settings(scenario, RUNNERS[method], steps, tolerances)],
                "series": None, "reference_error": str(exc), "comparisons": []}


def settings(scenario: Scenario, runner, steps, tolerances=None) -> list[tuple[float, float | None]]:
    """``(dt, rtol)`` of every run of a method: each step (coarse to fine) with no tolerance, or for an adaptive
    method each of its tolerances (loose to tight; default: the scenario's full ladder) at the scenario's
    ``adaptive_step``."""
    if runner.adaptive:
        return [(scenario.adaptive_step, float(tol)) for tol in (tolerances or scenario.tolerances)]
    return [(float(dt), None) for dt in steps]


def measure_method(scenario: Scenario, method: str, steps: tuple, partner: str | None, sample: bool = True,
                   tolerances: tuple | None = None, timing: bool = True) -> dict:
    """One method at every step of a scenario (an adaptive method: at every tolerance of ``tolerances``), run
    one at a time (what :func:`assemble` takes): its runs, with a ``partner`` the direct comparisons, and with
    ``sample`` the finest good run sampled for the figures (a sweep, which draws none, skips it)."""
    ctx = run_context(scenario)
    ref = scenario_reference(scenario)
    runner = RUNNERS[method]
    plan = settings(scenario, runner, steps, tolerances)
    _warm(runner, ctx, plan)
    runs, finest, comparisons = [], None, []
    for dt, rtol in plan:
        t0 = time.perf_counter()
        try:
            traj, wall, repeats = timed_run(runner, ctx, dt, rtol, max_runs=TIMING_REPEATS if timing else 1)
        except ValueError as exc:  # e.g. a step the run cannot take
            runs.append(Run.failed(dt, "failed", f"{method}: {exc}", time.perf_counter() - t0, rtol))
            continue
        run = measure_run(method, traj, ref, ctx, dt, wall, repeats=repeats, rtol=rtol)
        runs.append(run)
        if not run.ok:
            continue
        if timing:
            _retime_outliers(runner, ctx, runs)
        finest = (dt, traj)
        if partner is not None:
            difference = _difference(scenario, ctx, traj, partner, dt)
            if difference is not None:
                comparisons.append({"a": method, "b": partner, "dt": dt, "max_attitude_difference": difference})
    series = _sample(finest, ref, ctx) if finest is not None and sample else None
    return {"method": method, "runs": runs, "series": series, "comparisons": comparisons}


#: A run shorter than this [s] is repeated (up to :data:`TIMING_REPEATS` runs in all) until this much time is
#: spent, and its wall time is the best of those runs (``timeit``'s autorange, bounded): most runs of a quick
#: study take 0.1-5 ms, where one measurement is mostly timer noise and cache effects.
TIMING_BUDGET = 0.01
TIMING_REPEATS = 5


def timed_run(runner, ctx, dt: float, rtol: float | None = None, *, max_runs: int = TIMING_REPEATS):
    """``(trajectory, best wall time [s], runs timed)`` of ``runner`` at ``dt`` (and ``rtol``, an adaptive
    method's): repeated while short, up to ``max_runs`` runs (see :data:`TIMING_BUDGET`); the trajectory is the
    first run's (every run computes the same numbers)."""
    t0 = time.perf_counter()
    traj = runner.run_at(ctx, dt, rtol)
    best = spent = time.perf_counter() - t0
    runs = 1
    while traj.ok and runs < max_runs and spent < TIMING_BUDGET:
        t0 = time.perf_counter()
        runner.run_at(ctx, dt, rtol)
        wall = time.perf_counter() - t0
        best, spent, runs = min(best, wall), spent + wall, runs + 1
    return traj, best, runs


def measure_run(method: str, traj, ref, ctx: RunContext, dt: float, wall: float, *, repeats: int | None = None,
                rtol: float | None = None) -> Run:
    """One run's metrics against the reference ``ref`` (a failed :class:`Run` when the trajectory stopped or
    its errors are not finite); ``wall`` [s] is its wall time (the best of ``repeats`` runs), ``rtol`` an
    adaptive method's tolerance."""
    if not traj.ok:
        return Run.failed(dt, traj.status, traj.message, wall, rtol)
    q_ref, w_ref, mask = ref.at(traj.t)  # at the trajectory's own times (an engine's clock may round the step)
    err = errors_against(_subset(traj, mask), q_ref[mask], w_ref[mask])
    drift = invariant_drift(ctx.inertia, traj)
    torque_free = ctx.torque is None
    run = Run(dt=dt, **err, energy_drift=drift["energy_drift"] if torque_free else None,
              momentum_drift=drift["momentum_drift"] if torque_free else None, norm_drift=drift["norm_drift"],
              wall_time=wall, steps_per_second=_steps_per_second(dt, ctx.duration, wall),
              message=traj.extras.get("clock") or "", repeats=repeats, evaluations=traj.extras.get("evaluations"), rtol=rtol)
    if not all(v is None or math.isfinite(v) for v in run.to_json().values() if isinstance(v, float)):
        return Run.failed(dt, "failed", f"{method}: non-finite errors at dt = {dt:g} s", wall, rtol)
    return run


#: A run timed again because a run with more work took less time is re-run this many times more, at most.
RETIME_REPEATS = 3


def _retime_outliers(runner, ctx, runs) -> None:
    """Where the last run did more work than the good run before it (more evaluations, or a finer step or
    tolerance where the engine counts none) yet took less time, the earlier one met some noise (another process,
    the machine): it is timed again, up to :data:`RETIME_REPEATS` more runs, and keeps its best. Going back while
    that leaves its own predecessor slower, the work-precision line then runs forward wherever the work decides
    the time (where a run's fixed cost does, the two times are the same within noise)."""
    good = [r for r in runs if r.ok and r.wall_time is not None]
    for k in range(len(good) - 1, 0, -1):
        before, after = good[k - 1], good[k]
        if after.wall_time >= before.wall_time or not _more_work(after, before):
            return
        for _ in range(RETIME_REPEATS):
            t0 = time.perf_counter()
            runner.run_at(ctx, before.dt, before.rtol)
            before.wall_time = min(before.wall_time, time.perf_counter() - t0)
            before.repeats = (before.repeats or 1) + 1
            if before.wall_time <= after.wall_time:
                break
        before.steps_per_second = _steps_per_second(before.dt, ctx.duration, before.wall_time)


def _steps_per_second(dt: float, duration: float, wall: float) -> float | None:
    n, _ = step_plan(dt, duration)
    return n / wall if wall > 0 else None


def _more_work(a: Run, b: Run) -> bool:
    if a.evaluations is not None and b.evaluations is not None:
        return a.evaluations > b.evaluations
    return a.setting < b.setting


_WARM: set = set()


def _warm(runner, ctx, plan) -> None:
    """Load (or compile) a method's kernels, and what its runs load on the way for this scenario's torque (an
    engine's held-input module, its MuJoCo model), before its runs are timed: the first call in a process would
    otherwise charge a coarse step's wall time with ~10-200 ms of loading (the work-precision figure and the
    step-size table read those times)."""
    key = (runner.name, ctx.model_path, type(ctx.torque).__name__, getattr(getattr(ctx.torque, "field", None), "name", None))
    if key in _WARM or not plan:
        return
    _WARM.add(key)
    dt, rtol = min(plan)
    try:
        short = dataclasses.replace(ctx, duration=min(ctx.duration, 2 * dt))
        runner.run_at(short, dt, rtol)
    except ValueError:
        pass  # the timed runs will say why


def _difference(scenario, ctx, traj, partner: str, dt: float) -> float | None:
    """The largest attitude difference [rad] over the run between ``traj`` and ``partner`` at the same step
    (None when the partner's run did not complete). The partner's runs are kept per process: every engine
    method of the scenario is compared with the same one."""
    key = (_key(scenario), partner, dt)
    if key not in _PARTNER_RUNS:
        if any(k[0] != key[0] for k in _PARTNER_RUNS):  # another scenario: keep one scenario's runs only
            _PARTNER_RUNS.clear()
        try:
            _PARTNER_RUNS[key] = RUNNERS[partner].run(ctx, dt)
        except ValueError:
            _PARTNER_RUNS[key] = None
    other = _PARTNER_RUNS[key]
    if other is None or not other.ok or len(other.t) != len(traj.t) or not np.allclose(other.t, traj.t, rtol=0, atol=1e-12):
        return None
    value = float(np.max(rot.attitude_error(traj.q, other.q)))
    return value if math.isfinite(value) else None


def _subset(traj, mask):
    from .trajectory import Trajectory

    return Trajectory(t=traj.t[mask], q=traj.q[mask], omega=traj.omega[mask])


def _sample(finest, ref, ctx):
    """The finest good run sampled every PLOT_SAMPLE_DT (and its reference, errors and invariants)."""
    from .metrics import kinetic_energy, world_momentum

    dt, traj = finest
    stride = max(1, int(round(PLOT_SAMPLE_DT / dt)))
    idx = np.unique(np.concatenate([np.arange(0, len(traj.t), stride), [len(traj.t) - 1]]))
    t = traj.t[idx]
    q_ref, w_ref, mask = ref.at(t)
    q = traj.q[idx]
    out = {"dt": dt, "t": t, "q": q, "omega": traj.omega[idx], "q_ref": q_ref, "omega_ref": w_ref, "ref_mask": mask,
           "attitude_error": np.where(mask, rot.attitude_error(q, q_ref), np.nan)}
    E = kinetic_energy(ctx.inertia, out["omega"])
    H = world_momentum(ctx.inertia, q, out["omega"])
    out["energy_drift"] = E / E[0] - 1 if E[0] > 0 else np.zeros_like(E)
    out["momentum_drift"] = np.linalg.norm(H - H[0], axis=1) / max(np.linalg.norm(H[0]), 1e-300)
    if "euler" in traj.extras:
        out["euler"] = traj.extras["euler"][idx]
    if ctx.torque is not None:
        out["torque"] = ctx.torque.many(t, q, out["omega"])
    return out


# ------------------------------------------------------------------------------------------------
# back in the parent: orders, checks, verdict
# ------------------------------------------------------------------------------------------------
def study_floor(results) -> float:
    """The error below which a study does not measure orders: the larger of :data:`ORDER_FLOOR` and 10x
    the smallest error any method reached (which bounds the reference's own error from above)."""
    errs = [r.attitude_error for res in results for r in res["runs"] if r.attitude_error]
    return max(ORDER_FLOOR, 10 * min(errs)) if errs else ORDER_FLOOR


def assemble(scenario: Scenario, steps, results, *, quick: bool = False) -> StudyResult:
    """Orders, checks and verdicts from the workers' results. ``quick``: the final-error and invariant
    checks, which are about the finest steps of the full study, are not applied."""
    floor = study_floor(results)
    methods, series = {}, {}
    for res in results:
        name = res["method"]
        runner = RUNNERS[name]
        runs = res["runs"]
        x = [r.setting for r in runs]
        fit = observed_order(x, [r.attitude_error for r in runs], floor=floor)
        within = {tolerance_key(tol): largest_step_within(
            x, [r.max_attitude_error if r.ok else None for r in runs], [r.wall_time for r in runs], tol)
            for tol in TOLERANCES}
        order, note, local = fit.order, fit.note, fit.local_orders
        if runner.adaptive:  # its ladder is of tolerances: the slope is its tolerance proportionality, not an order
            order, local, note = None, [], _adaptive_note(runs, fit)
            within = {k: StepWithin(None, w.wall_time, w.how, rtol=w.dt) for k, w in within.items()}
        methods[name] = MethodResult(name=name, engine=runner.engine,
                                     expected_order=runner.order_for(scenario.torque)[0],
                                     runs=runs, observed_order=order, order_note=note,
                                     local_orders=local, within=within)
        if res["series"] is not None:
            series[name] = res["series"]
    reference_error = next((res["reference_error"] for res in results if res.get("reference_error")), None)
    if reference_error:
        checks = [Check("reference", False, note=f"the {scenario.reference} reference could not be computed: "
                                                 f"{reference_error}")]
    else:
        checks = _checks(scenario, methods, scenario.checks, quick)
    for m in methods.values():
        m.verdict = _verdict(m.name, checks)
    comparisons = [c for res in results for c in res.get("comparisons", ())]
    return StudyResult(scenario=scenario, steps=list(steps), methods=methods, checks=checks, order_floor=floor,
                       quick=quick, series=series, comparisons=comparisons)


def _verdict(method: str, checks) -> str:
    """``pass`` | ``fail`` | ``expected`` | ``info`` (see :mod:`xcheck.results`)."""
    if any(c.kind == "reference" and not c.passed for c in checks):
        return "fail"  # nothing could be measured
    related = [c for c in checks if c.method == method]
    if not related:
        return "info"
    if any(c.kind == "expected-failure" for c in related):
        return "expected" if all(c.passed for c in related) else "fail"
    return "pass" if all(c.passed for c in related) else "fail"


def _method_checks(m: MethodResult, cfg, torque_free, quick=False) -> list[Check]:
    """The regular checks of one method.

    A run that stops (singular, non-finite) fails the method only at its finest step: at coarse steps
    a method may legitimately be unstable, and the report shows those runs with their messages."""
    out = []
    expected = m.expected_order
    runs = sorted(m.runs, key=lambda r: r.setting)
    if runs and not runs[0].ok:
        out.append(Check("runs", False, m.name, note=runs[0].message or runs[0].status))
    finest = m.finest
    if expected is not None and finest is not None:
        order = m.observed_order
        if order is None:
            worst = max(r.attitude_error for r in runs if r.attitude_error is not None)
            out.append(Check("order", worst <= cfg["final_error"], m.name, None, expected,
                             f"no asymptotic range ({m.order_note}); every step within {worst:.2g} rad"))
        else:
            passed = expected - cfg["order_tolerance"] <= order <= expected + cfg["order_excess"]
            note = m.order_note
            if passed and order > expected + cfg["order_tolerance"]:
                note += "; faster than its order here: pre-asymptotic (the next error term still dominates)"
            out.append(Check("order", passed, m.name, order, expected, note))
        if expected >= 4 and not quick:
            out.append(Check("final-error", finest.attitude_error <= cfg["final_error"], m.name,
                             finest.attitude_error, cfg["final_error"], f"at dt = {finest.dt:g} s"))
    if torque_free and finest is not None and expected is not None and expected >= 4 and not quick:
        drift = max(finest.energy_drift, finest.momentum_drift)
        out.append(Check("invariants", drift <= cfg["invariant_tolerance"], m.name, drift, cfg["invariant_tolerance"],
                         f"energy and momentum drift at dt = {finest.dt:g} s"))
    return out


def planned_checks(scenario: Scenario, methods, quick: bool = False) -> list[tuple[str, str]]:
    """``(method, kind)`` of every check a study of ``methods`` makes, known before it runs (what the pytest
    plugin turns into test items): per method ``runs`` (its finest run completed), ``order`` (with an expected
    order), ``final-error`` and, torque free, ``invariants`` (order >= 4, full studies), ``agreement`` (an
    engine's RK4, when the study has one of our fourth-order methods); ``expected-failure`` instead of all of
    them for a method the scenario expects to fail. Kept beside :func:`_checks`, which makes them."""
    cfg = scenario.checks
    torque_free = scenario.torque is None
    ours4 = any(RUNNERS[m].engine == "xcheck" and RUNNERS[m].expected_order == 4 and m not in cfg["expected_to_fail"]
                for m in methods)
    out = []
    for m in methods:
        runner = RUNNERS[m]
        if m in cfg["expected_to_fail"]:
            out.append((m, "expected-failure"))
            continue
        out.append((m, "runs"))
        order = runner.order_for(scenario.torque)[0]
        if order is not None:
            out.append((m, "order"))
            if order >= 4 and not quick:
                out.append((m, "final-error"))
                if torque_free:
                    out.append((m, "invariants"))
        if runner.agreement and ours4 and runner.order_for(scenario.torque)[1] is None:
            out.append((m, "agreement"))
    return out


def _adaptive_note(runs, fit) -> str:
    """An adaptive method's order note: how its error goes with the tolerance (the slope fitted over ``rtol``)."""
    if not runs:
        return ""
    if fit.order is None:
        return f"adaptive, at its own tolerances: {fit.note}"
    fitted = fit.note.replace("dt = ", "rtol = ").replace(" s", "")
    return (f"adaptive, at its own tolerances (output every {step_label(runs[0].dt)} s): the error goes as "
            f"rtol^{fit.order:.2f} ({fitted})")


def _checks(scenario, methods, cfg, quick=False) -> list[Check]:
    torque_free = scenario.torque is None
    checks = []
    for m in methods.values():
        regular = _method_checks(m, cfg, torque_free, quick)
        if m.name in cfg["expected_to_fail"]:
            failing = [c for c in regular if not c.passed]
            note = "; ".join(f"{c.name} fails" + (f" ({c.note})" if c.note else "") for c in failing)
            checks.append(Check("expected-failure", bool(failing), m.name,
                                note=note or "expected to fail, but every check passed"))
        else:
            checks += regular
    # every engine's RK4 against our best fourth-order method, at their finest steps
    ours = [m for m in methods.values() if m.engine == "xcheck" and m.expected_order == 4
            and m.name not in cfg["expected_to_fail"] and m.finest is not None]
    if ours:
        best = min(ours, key=lambda m: m.finest.attitude_error)
        for m in methods.values():
            runner = RUNNERS[m.name]
            if not runner.agreement or m.finest is None or runner.order_for(scenario.torque)[1] is not None:
                continue  # an engine's RK4 whose input is held over a step is not the same method as ours
            worst = max(m.finest.attitude_error, best.finest.attitude_error)
            checks.append(Check("agreement", worst <= cfg["agreement"], m.name, worst, cfg["agreement"],
                                f"{m.name} {m.finest.attitude_error:.3g} rad and {best.name} "
                                f"{best.finest.attitude_error:.3g} rad against the {scenario.reference} reference at "
                                "their finest steps"))
    return checks


def throughput_rows(studies) -> list[dict]:
    """Best steps per second of every method in every study (``xcheck.bench/1`` rows, batch 1)."""
    rows = []
    for st in studies:
        for name, m in st.methods.items():
            rates = [r.steps_per_second for r in m.runs if r.steps_per_second]
            if rates:
                rows.append({"engine": m.engine, "method": name, "scenario": st.name, "batch": 1,
                             "steps_per_second": max(rates)})
    return rows
