"""Measuring a method (in a worker): every run of it against the scenario's reference, timed the way ``timeit``'s
autorange does, the direct comparison with its partner, and the finest good run sampled for the figures."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from .. import rotations as rot
from .._jit import compiled_code_loaded
from ..invariants import CHANGE_KEYS, LAW_KEYS, invariant_series, law_samples
from ..metrics import errors_against, invariant_changes
from ..motion import flips_of, precession_of, resolves_flips, resolves_precession, tumbles
from ..reference import ReferenceFailure
from ..results import MethodRuns, Run
from ..runners import RUNNERS, RunContext
from ..scenario import Scenario
from ..trajectory import same_step, step_plan
from .context import run_context, scenario_key, scenario_reference

__all__ = ["run_methods", "run_method", "measure_method", "measure_run", "timed_run", "settings", "PLOT_SAMPLE_DT"]

#: Series kept for plots and CSV are sampled at this spacing [s] (or every step, if coarser).
PLOT_SAMPLE_DT = 1 / 256
_PARTNER_RUNS: dict = {}  # (scenario key, partner, dt) -> Trajectory | None (see _difference)


def run_methods(scenario: Scenario, methods: tuple, steps: tuple, partners: tuple, tolerances: tuple | None = None,
                timing: bool = True) -> list[MethodRuns]:
    """One task of a study (in a worker): :func:`run_method` for each of ``methods``, its ``steps`` and ``partner``
    the same place in ``steps`` and ``partners`` (one method; or every method of an engine that runs as one task)."""
    return [run_method(scenario, m, st, partner, tolerances, timing) for m, st, partner in zip(methods, steps, partners)]


def run_method(scenario: Scenario, method: str, steps: tuple, partner: str | None = None,
                tolerances: tuple | None = None, timing: bool = True) -> MethodRuns:
    """All steps of one method (in a worker): per-run metrics, the sampled finest good run, and with a
    ``partner`` (:func:`comparison_partner`) the largest attitude difference between the two at every step."""
    import warnings

    warnings.filterwarnings("ignore", category=UserWarning, module="xcheck.models")
    try:
        return measure_method(scenario, method, steps, partner, tolerances=tolerances, timing=timing)
    except ReferenceFailure as exc:  # building or evaluating it: nothing can be measured; the study fails, saying why
        return MethodRuns.without_reference(method, settings(scenario, RUNNERS[method], steps, tolerances), exc)
    except ImportError as exc:  # an engine installed but broken here (a missing shared library): the study says so
        if RUNNERS[method].engine == "xcheck":
            raise
        return MethodRuns(method, [], import_error=f"{type(exc).__name__}: {exc}")


def settings(scenario: Scenario, runner, steps, tolerances=None) -> list[tuple[float, float | None]]:
    """``(dt, rtol)`` of every run of a method: each step (coarse to fine) with no tolerance, or for an adaptive
    method each of its tolerances (loose to tight; default: the scenario's full ladder) at the scenario's
    ``adaptive_step``."""
    if runner.adaptive:
        return [(scenario.adaptive_step, float(tol)) for tol in (tolerances or scenario.tolerances)]
    return [(float(dt), None) for dt in steps]


def measure_method(scenario: Scenario, method: str, steps: tuple, partner: str | None, sample: bool = True,
                   tolerances: tuple | None = None, timing: bool = True) -> MethodRuns:
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
        if rtol is None and scenario.your_step is not None and same_step(dt, scenario.your_step):
            _motion(run, traj, ref, ctx)
        finest = (dt, traj, run)
        if partner is not None:
            comparisons.append(_compare(scenario, ctx, traj, method, partner, dt))
    if finest is not None:
        _motion(finest[2], finest[1], ref, ctx)
    series = _sample(finest[:2], ref, ctx) if finest is not None and sample else None
    return MethodRuns(method, runs, series=series, comparisons=[c for c in comparisons if c is not None],
                      reference_check=ref.check, reference_flips=ref.flips(), built=_built(runner, ctx),
                      reference_precession=(ref.precession() or {}).get("reference"))


def _motion(run: Run, traj, ref, ctx: RunContext) -> None:
    """The motion's own numbers of a run (:mod:`xcheck.motion`: a tumbler's flips, a top's cone), where its step
    resolves the reference's; measured for the runs the answers quote only (the user's step, the finest: a study's
    other runs would cost a millisecond each for numbers nobody reads)."""
    if tumbles(ctx.inertia, ctx.omega0) and resolves_flips(run.dt, ref.flips()):
        run.flips = flips_of(ctx.inertia, traj.t, traj.omega)
    cone = ref.precession()
    if cone is not None and resolves_precession(run.dt, cone["reference"]):
        run.precession = _cone_against(traj, ref, cone)


def _built(runner, ctx) -> dict | None:
    """What the method's engine was given for the body: ``{"body": ..., "engine": ...}``
    (:mod:`xcheck.engines.built`), None for an engine not known there."""
    from ..engines.built import body_built, how_built
    from ..engines.mechanism import mechanism_of

    try:
        mechanism = mechanism_of(ctx)
    except ValueError:  # a bus that is no rigid body: the engine's run says so
        mechanism = None
    engine = how_built(runner.engine, mechanism)
    return None if engine is None else {"body": body_built(mechanism), "engine": engine}


def _cone_against(traj, ref, cone) -> dict | None:
    """The run's precession and nutation (:func:`xcheck.motion.precession_of`) with their errors against the
    reference's measured the same way on the run's own times (``precession_error`` [rad/s], ``nutation_error`` [s]:
    the method's less the reference's), so that what the sampling costs both cancels; None where the reference is
    not known at every time of the run (a fine run's grid)."""
    q_ref, _, mask = ref.at(traj.t)
    if not mask.all():
        return None
    got = precession_of(traj.t, traj.q, cone["frame"], cone["level"])
    want = precession_of(traj.t, q_ref, cone["frame"], cone["level"])
    nutation = (None if got["nutation_period"] is None or want["nutation_period"] is None else
                got["nutation_period"] - want["nutation_period"])
    return {**got, "precession_error": got["precession"] - want["precession"], "nutation_error": nutation,
            "cone_error": got["cone_change"] - want["cone_change"]}


def _compare(scenario, ctx, traj, method: str, partner: str, dt: float, now: bool = False) -> dict | None:
    """The direct comparison of ``traj`` with ``partner``'s run at the same step, or, in a process that has not
    loaded our compiled code (a worker that only drives Basilisk: its first load costs 0.3-0.5 s, on the path
    of every study that waits for that worker), the run's times and attitudes, for the process that assembles
    the study to compare (:func:`resolve_comparisons`): the same numbers either way."""
    if not (now or compiled_code_loaded()):
        return {"a": method, "b": partner, "dt": dt, "later": (traj.t, traj.q)}
    difference = _difference(scenario, ctx, traj, partner, dt)
    return None if difference is None else {"a": method, "b": partner, "dt": dt, "max_attitude_difference": difference}


def resolve_comparisons(scenario: Scenario, comparisons: list) -> list:
    """``comparisons`` with those a worker left to this process (:func:`_compare`) made here."""
    from ..trajectory import Trajectory

    out = []
    for c in comparisons:
        if "later" in c:
            t, q = c["later"]
            c = _compare(scenario, run_context(scenario), Trajectory(t=t, q=q, omega=np.zeros((len(t), 3))),
                         c["a"], c["b"], c["dt"], now=True)
        if c is not None:
            out.append(c)
    return out


#: A run shorter than this [s] is repeated (up to :data:`TIMING_REPEATS` runs in all) until this much time is
#: spent, and its wall time is the best of those runs (``timeit``'s autorange, bounded): most runs of a quick
#: study take 0.1-5 ms, where one measurement is mostly timer noise and cache effects. (2 ms: the work-precision
#: lines as monotone as at 5 ms, and 2.5 s less CPU in a full report; session 12.)
TIMING_BUDGET = 0.002
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
    said = _said(method, traj)
    if not traj.ok:
        return Run.failed(dt, traj.status, "; ".join(x for x in (traj.message, said) if x), wall, rtol)
    q_ref, w_ref, mask = ref.at(traj.t)  # at the trajectory's own times (an engine's clock may round the step)
    err = (errors_against(traj, q_ref, w_ref) if mask.all() else
           errors_against(_subset(traj, mask), q_ref[mask], w_ref[mask]))
    kept = invariant_changes(ctx.inertia, traj, ctx.torque)  # under a torque: what it keeps, if anything
    run = Run(dt=dt, **err, **_laws(ctx, traj, kept), energy_change=kept["energy_change"],
              momentum_change=kept["momentum_change"],
              momentum_turn=kept["momentum_turn"], spin_change=kept.get("spin_change"), norm_drift=kept["norm_drift"],
              wheel_speed_error=_wheel_speed_error(traj, ctx.torque, q_ref, w_ref, mask),
              wall_time=wall, steps_per_second=_steps_per_second(dt, ctx.duration, wall),
              message="; ".join(x for x in (traj.extras.get("clock"), traj.extras.get("substeps_note"), said) if x),
              repeats=repeats, evaluations=traj.extras.get("evaluations"), substeps=traj.extras.get("substeps"),
              rtol=rtol)
    if not all(v is None or math.isfinite(v) for v in run.to_json().values() if isinstance(v, float)):
        return Run.failed(dt, "failed", f"{method}: non-finite errors at dt = {dt:g} s", wall, rtol)
    return run


#: A run's note of what its engine wrote to the standard error starts with this, after the engine's name.
SAID = " said: "


def _said(method: str, traj) -> str:
    """What the run's engine wrote to the standard error (:func:`xcheck.base.captured.engine_said`), as a run's note:
    ``DART said: Warning [BodyNode.cpp:633] ...`` (its first three lines, and how many more); "" where nothing."""
    lines = traj.extras.get("engine_said") or []
    if not lines:
        return ""
    from ..engines.built import ENGINE_NAMES

    engine = RUNNERS[method].engine
    more = f" (and {len(lines) - 3} more lines)" if len(lines) > 3 else ""
    return f"{ENGINE_NAMES.get(engine, engine)}{SAID}{' | '.join(lines[:3])}{more}"


def _laws(ctx: RunContext, traj, kept: dict) -> dict:
    """The invariants' laws over a run with their directions (:meth:`~xcheck.invariants.InvariantSeries.laws`),
    fitted on :func:`~xcheck.invariants.law_samples` (49 samples: a run's cost is its steps, not these), signed by
    the run's largest changes ``kept``; {} where the motion keeps none."""
    if all(kept[key] is None for key in CHANGE_KEYS):
        return {}
    n = len(traj.t) - 1
    idx = law_samples(n)
    laws = invariant_series(ctx.inertia, traj.q[idx], traj.omega[idx], ctx.torque, traj.t[idx]).laws(traj.t[idx], n,
                                                                                                      kept)
    return {key: laws[key] for key in LAW_KEYS}


def _wheel_speed_error(traj, torque, q_ref, w_ref, mask) -> float | None:
    """A gyrostat's largest wheel-speed error over the run [rad/s]: the engine's own wheels' speeds (MuJoCo's
    hinges, ``extras["wheel_speeds"]``), or ours from the wheels' momentum and the run's body rate
    (:meth:`~xcheck.fields.WheelsTorque.wheel_speeds`), against the reference's; None without wheels."""
    wheels = next((term for term in getattr(torque, "terms", [torque]) if hasattr(term, "wheel_speeds")), None)
    if wheels is None or not wheels.wheels:
        return None
    t = traj.t[mask]
    own = traj.extras.get("wheel_speeds")
    got = own[mask] if own is not None else wheels.wheel_speeds(t, traj.omega[mask])
    return float(np.max(np.abs(got - wheels.wheel_speeds(t, w_ref[mask])))) if len(t) else None


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
    step-size table read those times). Once a process for each method and kind of torque, and once a model for the
    engines that compile the MJCF (MuJoCo's, MJX's): the others load nothing a model's own, and a warm run of
    Basilisk's is its whole setup again (a second of a quick report's CPU when warmed for every scenario)."""
    model = ctx.model_path if runner.engine in ("mujoco", "mjx") else None
    key = (runner.name, model, type(ctx.torque).__name__, getattr(getattr(ctx.torque, "field", None), "name", None))
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
    key = (scenario_key(scenario), partner, dt)
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
    from ..trajectory import Trajectory

    return Trajectory(t=traj.t[mask], q=traj.q[mask], omega=traj.omega[mask])


def _sample(finest, ref, ctx):
    """The finest good run sampled every PLOT_SAMPLE_DT (and its reference, errors and invariants)."""

    dt, traj = finest
    stride = max(1, int(round(PLOT_SAMPLE_DT / dt)))
    idx = np.unique(np.concatenate([np.arange(0, len(traj.t), stride), [len(traj.t) - 1]]))
    t = traj.t[idx]
    q_ref, w_ref, mask = ref.at(t)
    q = traj.q[idx]
    out = {"dt": dt, "t": t, "q": q, "omega": traj.omega[idx], "q_ref": q_ref, "omega_ref": w_ref, "ref_mask": mask,
           "attitude_error": np.where(mask, rot.attitude_error(q, q_ref), np.nan)}
    kept = invariant_series(ctx.inertia, q, out["omega"], ctx.torque, t)  # signed; None where not kept
    out |= {"energy_change": kept.energy, "momentum_change": kept.momentum, "momentum_turn": kept.turn,
            "energy_label": kept.energy_label, "momentum_label": kept.momentum_label}
    if "euler" in traj.extras:
        out["euler"] = traj.extras["euler"][idx]
    if ctx.torque is not None:
        out["torque"] = ctx.torque.many(t, q, out["omega"])
    return out
