"""``xcheck report`` (the main job), ``xcheck nightly`` (the report, compared with the history and recorded in it)
and ``xcheck bench`` (steps per second of every method)."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

from ..base.errors import UsageError
from . import Context, Outcome
from .arguments import methods_arg, releases_arg, user_scenario
from .arguments import with_engines as add_engines
from .studies import study_lines


@dataclass
class ReportOutcome(Outcome):
    report: object  # xcheck.report.build.ReportOutcome


def report(*, scenarios: list[str], out: str, quick: bool, bench: bool, timings: bool, trajectories: bool,
           with_engines: str | None, workers: int | None, ctx: Context, horizon: bool = False,
           duration: str | None = None, tolerance: str | None = None) -> ReportOutcome:
    """The cross-check report of ``scenarios`` (every bundled one when empty) into ``out/<stamp>/``, each over
    ``duration`` where given, judged against ``tolerance`` (``--duration``, ``--tolerance``:
    :func:`~xcheck.commands.arguments.user_scenario`)."""
    from ..report.build import build_report, resolve_scenarios

    t0 = time.perf_counter()
    add_engines(with_engines)
    if duration is not None or tolerance is not None:  # resolved here (else while the workers start)
        scenarios = resolve_scenarios(scenarios, resolve=lambda name: user_scenario(name, duration, tolerance))
    built = build_report(scenarios, out, quick=quick, workers=workers, run_bench=bench, trajectories=trajectories,
                         progress=ctx.progress(), written=ctx.written.append, started=ctx.started, horizons=horizon)
    if timings:
        ctx.note(built.timings())
    for st in built.studies:
        for line in study_lines(st):
            ctx.say(line)
    ctx.say(f"\nreport: {built.folder}/index.html ({built.outcome}); wall time {time.perf_counter() - t0:.1f} s")
    return ReportOutcome(built.outcome, built)


@dataclass
class NightlyOutcome(Outcome):
    nightly: object  # xcheck.history.nightly.NightlyOutcome


def nightly(*, scenarios: list[str], out: str, history: str | None, baseline: int | None, last: int,
            keep: int | None, error_factor: float, order_drop: float, speed_drop: float, bench: bool,
            mujoco: str | None, quick: bool, workers: int | None, ctx: Context) -> NightlyOutcome:
    """The full report, compared with the history, then recorded in it (:mod:`xcheck.history.nightly`); FAILED
    when something regressed."""
    from ..base.files import check_output_dir
    from ..history import nightly as N
    from ..report.build import resolve_scenarios

    if keep is not None and keep < 1:
        raise UsageError(f"--keep: expected a positive number of report folders, got {keep}")
    if last < 1:
        raise UsageError(f"--last: expected a positive number of runs, got {last}")
    for name, value, top in (("--error-factor", error_factor, None), ("--order-drop", order_drop, None),
                             ("--speed-drop", speed_drop, 1.0)):
        if not (value > 0 and (top is None or value <= top) and value != float("inf")):
            raise UsageError(f"{name}: expected a positive number{' at most 1' if top else ''}, got {value}")
    thresholds = N.H.Thresholds(error_factor=error_factor, order_drop=order_drop, speed_drop=speed_drop)
    versions = releases_arg(mujoco, ctx) if mujoco is not None else []
    resolved = resolve_scenarios(scenarios)
    check_output_dir(out, "--out")
    if history is not None and not history.strip():
        raise UsageError("--history: expected a SQLite file or a postgresql:// URL, got an empty string")
    location = history or N.default_history(out)
    done = N.run_nightly(resolved, out, location=location, baseline=baseline, last=last, thresholds=thresholds,
                         versions=versions, quick=quick, workers=workers, bench=bench, keep=keep,
                         progress=ctx.progress(), written=ctx.written.append, started=ctx.started)
    for st in done.report.studies:
        for line in study_lines(st):
            ctx.say(line)
    ctx.say("")
    for cmp in done.comparisons:
        for line in cmp.lines():
            ctx.say(line)
    if done.removed:
        n = len(done.removed)
        ctx.say(f"--keep {keep}: removed {n} older report folder{'s' * (n > 1)}")
    ctx.say(f"\nnightly: run {done.run_id} recorded in {N.H.display(location)}; report "
            f"{done.report.folder}/index.html ({done.verdict()}); wall time {done.wall_time:.1f} s")
    return NightlyOutcome("FAILED" if done.regressions else done.report.outcome, done)


@dataclass
class BenchOutcome(Outcome):
    rows: list


def bench(*, json: str | None, quick: bool, methods: str | None, repeat: int, with_engines: str | None,
          ctx: Context) -> BenchOutcome:
    """Steps per second of every method (or ``methods``), ours and the engines', best of ``repeat`` runs."""
    from ..base.files import check_output_file, write_json_atomic
    from ..bench import format_rows, run_bench
    from ..versions import versions

    add_engines(with_engines)
    if repeat < 1:
        raise UsageError(f"--repeat: expected a positive number of runs, got {repeat}")
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    chosen = methods_arg(methods) if methods is not None else None
    live = sys.stderr.isatty()
    rows = run_bench(repeat=repeat, quick=quick, methods=chosen,
                     progress=(lambda r: ctx.note(f"  {r['engine']} {r['method']} {r['scenario']} batch={r['batch']}: "
                                                  f"{r['steps_per_second']:.3g} steps/s")) if live else None)
    ctx.say(format_rows(rows))
    if json:
        write_json_atomic(json, {"schema": "xcheck.bench/1", "versions": versions(), "results": rows})
    return BenchOutcome("PASSED", rows)
