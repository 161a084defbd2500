"""``xcheck list``, ``xcheck converge`` (one convergence study) and ``xcheck run`` (one trajectory)."""

from __future__ import annotations

import math
import time
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

from ..base.errors import UsageError
from . import Context, Outcome
from .arguments import clock_note, methods_arg, steps_arg, user_scenario

#: The formats ``run --plot`` writes, by file ending.
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


def list_all(*, ctx: Context) -> Outcome:
    """The bundled scenarios and sweeps (each described, or why it cannot be read) and every method."""
    from ..runners import RUNNERS
    from ..scenario import ScenarioError, bundled_scenarios, load_scenario
    from ..sweep.spec import bundled_sweeps, load_sweep

    for title, files, load in (("Bundled scenarios (models/scenarios/):", bundled_scenarios(), load_scenario),
                               ("\nBundled sweeps (models/sweeps/; xcheck sweep NAME):", bundled_sweeps(), load_sweep)):
        ctx.say(title)
        for name, path in files.items():
            try:
                desc = load(path).description
            except ScenarioError as exc:
                desc = f"(invalid: {exc})"
            ctx.say(f"  {name:28s} {desc}")
    ctx.say("\nMethods:")
    for name, r in RUNNERS.items():
        order = r.expected_order if r.expected_order is not None else "adaptive"
        ctx.say(f"  {name:22s} order {order!s:9s} {r.summary}")
    return Outcome("PASSED")


def study_lines(st) -> list[str]:
    """A study as the terminal shows it: the verdict, one line per method, each failed or undecided check."""
    from ..study import engine_said_lines, finer_lines, left_out_lines
    from ..study.checks import check_summary
    from ..study.your_step import answer_line

    lines = [f"\n{st.name}: {st.outcome} (reference: {st.reference_used})"]
    answer = st.your_step
    if answer:  # the user's question first: at their step, over their run
        lines.append(f"  {answer_line(answer)}")
    if st.reference_check:
        lines.append(f"  reference: {st.reference_check['text']}")
    lines += method_table(st)
    lines += flips_table(st)
    lines += precession_table(st)
    lines += advice_block(st)
    lines += built_block(st)
    lines += [f"  {line}" for line in left_out_lines(st)]
    lines += [f"  {line}" for line in finer_lines(st)]
    lines += [f"  {line}" for line in engine_said_lines(st)]
    if st.files:
        from .score import file_lines

        lines += file_lines(list(st.files.values()))
    for c in st.checks:
        if not c.passed and c.kind != "file":  # a file's failure: its sentence above
            summary = check_summary(c, st.scenario.checks)
            detail = f"; {c.note}" if c.note and c.note != summary else ""
            if c.known:  # explained by a known finding of its engine: the finding, not the numbers again
                lines.append(f"  KNOWN {c.name}: {summary}; {c.known}")
                continue
            lines.append(f"  {'INCONCLUSIVE' if c.inconclusive else 'FAILED'} {c.name}: {summary}{detail}")
    lines.extend(f"  INCONCLUSIVE: {why}" for why in st.inconclusive)
    return lines


def method_table(st) -> list[str]:
    """One row per method, its two statements apart (:mod:`xcheck.study.statements`): the orders, its finest error
    and its step, its largest error at the user's step, the invariants there (signed), whether it behaves as its
    theory says (consistent) and whether it is within the tolerance (accurate), with the step where rows differ."""
    from ..study.statements import accurate_text, invariants_text, usual_place, where_text
    from ..trajectory import step_label

    answer = st.your_step
    usual = usual_place(st.methods.values())
    tol = next((m.accurate["tolerance"] for m in st.methods.values() if m.accurate is not None), None)
    yours = answer is not None and answer["studied"]
    at = f"at {step_label(answer['dt'])} s" if yours else "at the finest step"
    width = max([22, *map(len, st.methods)])  # the engines' longest names (drake-semi-explicit-euler) fit
    out = [f"  consistent: the order and invariants its theory gives; accurate: its largest attitude error over the run "
           f"within {tol if tol is not None else '—'} rad {at}; invariants there: the largest relative change over "
           "the run (+ gained, - damped) and its growth, and the angle [rad] L's direction turned"]
    out.append(f"  {'method':{width}s} {'expected':>8s} {'observed':>8s}  {'finest error':<24s} {'energy':<18s} "
               f"{'|L|':<18s} {'L turned':>8s}  {'consistent':<16s} accurate {at}")
    for name, m in st.methods.items():
        obs = f"{m.observed_order:.2f}" if m.observed_order is not None else "—"
        exp = m.expected_order if m.expected_order is not None else "adaptive"
        f = m.finest
        finest = "—" if f is None else f"{f.attitude_error:.2e} at {where_text(f)}"
        a = m.accurate
        energy, size, turn = invariants_text(a)
        consistent = m.consistent + ("" if m.status == "ok" or f is None else f", {m.status_text}")
        accurate = accurate_text(a, show_step=a is not None and where_text(a) != usual)
        out.append(f"  {name:{width}s} {exp!s:>8s} {obs:>8s}  {finest:<24s} {energy:<18s} {size:<18s} {turn:>8s}  "
                   f"{consistent:<16s} {accurate}")
    return out


def _motion_table(st, table, columns) -> list[str]:
    """A motion table (:func:`~xcheck.study.statements.flip_rows`' or ``precession_rows``' ``(head, rows)``) in the
    terminal: ``columns`` one ``(title, width, format)`` per value after the method and its step ("—" for None)."""
    if table is None:
        return []
    head, rows = table
    width = max([22, *map(len, st.methods)])
    out = [f"  {head}", f"  {'method':{width}s} {'at':>12s} " + " ".join(f"{t:>{w}s}" for t, w, _ in columns)]
    for name, at, *values in rows:
        cells = (f"{'—':>{w}s}" if v is None else f"{v:{fmt.format(w)}}" for v, (_, w, fmt) in zip(values, columns))
        out.append(f"  {name:{width}s} {at:>12s} " + " ".join(cells))
    return out


def flips_table(st) -> list[str]:
    """A tumbling body's flips per method (:func:`~xcheck.study.statements.flip_rows`); [] where it does not tumble."""
    from ..study.statements import flip_rows

    return _motion_table(st, flip_rows(st), [("flips", 5, "{}d"), ("first [s]", 11, "{}.6g"),
                                             ("Δ first [s]", 12, "+{}.1e"), ("every [s]", 11, "{}.6g"),
                                             ("Δ every [s]", 12, "+{}.1e")])


def precession_table(st) -> list[str]:
    """A top's or an axisymmetric body's cone per method (:func:`~xcheck.study.statements.precession_rows`)."""
    from ..study.statements import precession_rows

    return _motion_table(st, precession_rows(st), [("precession [rad/s]", 19, "{}.7g"), ("Δ [rad/s]", 10, "+{}.1e"),
                                                   ("nutation [s]", 12, "{}.6g"), ("Δ [s]", 9, "+{}.1e"),
                                                   ("cone Δ [rad]", 12, "+{}.1e")])


def built_block(st) -> list[str]:
    """What each engine was given for the body, a line per engine (:mod:`xcheck.engines.built`)."""
    from ..engines.built import ENGINE_NAMES

    if not st.built:
        return []
    return [f"  what each engine was given ({st.built['body']}):",
            *(f"    {ENGINE_NAMES.get(e, e)}: {text}" for e, text in st.built["engines"].items())]


def advice_block(st) -> list[str]:
    """What to use instead, a line per engine (:mod:`xcheck.study.advice`)."""
    from ..study.advice import advice_lines

    lines = advice_lines(st)
    if not lines:
        return []
    return ["  what to use instead: per engine, the cheapest of its integrators at the largest step this study ran "
            "that keeps the tolerance over the run (there and at every finer step)", *(f"    {x}" for x in lines)]


@dataclass
class StudyOutcome(Outcome):
    study: object  # xcheck.study.StudyResult


def converge(*, scenario: str, methods: str | None, steps: str | None, quick: bool, json: str | None,
             out: str | None, workers: int | None, ctx: Context, duration: str | None = None,
             tolerance: str | None = None) -> StudyOutcome:
    """One convergence study of ``scenario``. A study is quicker in this process than shared with workers, which
    each pay 1-1.5 s of imports and compiled-code loading before their first run, except for the methods of an
    engine whose import is costly (Basilisk's: 0.5 s more, and the longest runs). With one installed (and not left
    out by ``methods``) one worker starts before anything is imported here, imports it, and runs its methods while
    this process runs the rest (:func:`converge_workers`). ``workers`` N: that many processes for the whole study;
    1: this process alone."""
    from ..base.pool import worker_pool
    from ..study.executor import worker_modules

    size, engines = converge_workers(methods, workers)
    with worker_pool(size, warm=worker_modules(figures=False, engines=engines)) if size else nullcontext() as pool:
        return _converge(scenario, methods, steps, quick, json, out, pool, ctx, duration, tolerance)


def converge_workers(methods: str | None, workers: int | None) -> tuple[int, list | None]:
    """``(workers beside this process, the engines they import as they start)`` for a converge of ``--methods``
    ``methods`` (None: the scenario's) and ``--workers`` ``workers`` (see :func:`converge`). The methods are read
    by their engines' prefixes here, before anything is imported; their names are checked once the scenario is
    read. A worker imports only the engines ``methods`` names (``None``: every one installed whose import is
    costly); where every method named is such an engine's, no worker starts (this process would only wait for its
    imports: ``--methods drake-rk3`` 2.1 -> 1.1 s)."""
    from ..engines import ENGINES, available

    costly = [e.name for e in ENGINES.values() if e.to_workers and available(e.name)]
    prefixes = None if methods is None else {m.strip().split("-", 1)[0] for m in methods.split(",")}
    named = costly if prefixes is None else [name for name in costly if name in prefixes]
    beside = prefixes is None or not prefixes <= set(named)  # ours, MuJoCo's: this process's own work meanwhile
    size = workers - 1 if workers and workers > 1 else (1 if workers is None and named and beside else 0)
    return size, None if prefixes is None else named


def _converge(name, methods, steps, quick, json, out, pool, ctx, duration=None, tolerance=None) -> StudyOutcome:
    from ..base.files import check_output_dir, check_output_file, write_json_atomic
    from ..runners import RUNNERS
    from ..study import default_methods, run_study

    scenario = user_scenario(name, duration, tolerance)
    methods = methods_arg(methods) if methods is not None else None
    steps = steps_arg(steps, scenario) if steps is not None else None
    for m in (methods or default_methods(scenario)) if steps else ():  # an unknown name: run_study's refusal
        for dt in steps if m in RUNNERS else ():
            clock_note(RUNNERS[m], dt, "--steps")
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    if out:
        check_output_dir(out, "--out")
    t0 = time.perf_counter()
    # a run's wall time is repeated for a meaningful figure only where one is written (the table shows none)
    st = run_study(scenario, methods=methods, steps=steps, quick=quick, workers=1 if pool is None else None,
                   progress=ctx.progress(), timing=bool(json or out), pool=pool, here=pool is not None)
    for line in study_lines(st):
        ctx.say(line)
    if json:
        write_json_atomic(json, st.data)
    if out:
        from ..report.plots import scenario_figures

        files = scenario_figures(st.data, st.series, out)
        ctx.say(f"  figures: {', '.join(str(Path(out) / f) for f, _ in files)}")
    ctx.say(f"wall time {time.perf_counter() - t0:.1f} s")
    return StudyOutcome(st.outcome, st)


@dataclass
class RunOutcome(Outcome):
    run: object  # xcheck.study.single.SingleRun


def run_one(*, scenario: str, method: str, dt: float, rtol: float | None, csv: str | None, plot: str | None,
            ctx: Context, duration: str | None = None) -> RunOutcome:
    """One trajectory of ``method`` at the step ``dt`` against the scenario's reference; FAILED when the run did
    not end (non-finite, singular) or has no reference."""
    from ..base.files import check_output_file, write_trajectory_csv
    from ..runners import RUNNERS, unknown_method
    from ..study.single import run_once
    from ..trajectory import check_step

    sc = user_scenario(scenario, duration)
    if method not in RUNNERS:
        raise UsageError(f"--method: {unknown_method(method)}")
    runner = RUNNERS[method]
    if rtol is not None and not runner.adaptive:
        raise UsageError(f"--rtol: {method} is a fixed-step method; a tolerance applies to an adaptive one "
                         f"({', '.join(n for n, r in RUNNERS.items() if r.adaptive)})")
    if rtol is not None and not (math.isfinite(rtol) and 0 < rtol < 1):
        raise UsageError(f"--rtol: expected a relative tolerance in (0, 1), got {rtol:g}")
    try:
        check_step(dt, sc.duration, runs_at_once=1)
    except ValueError as exc:
        raise UsageError(f"--dt: {exc} (scenario {sc.name}, duration {sc.duration:g} s)") from None
    note = clock_note(runner, dt, "--dt")
    if csv:
        check_output_file(csv, "--csv", suffixes=(".csv",))
    if plot:
        check_output_file(plot, "--plot", suffixes=PLOT_SUFFIXES)
    if note:
        ctx.say(f"note: {note}")
    one = run_once(sc, runner, dt, rtol)
    traj, err = one.traj, one.error
    ctx.say(f"{sc.name} / {method} at dt = {dt:g} s: {traj.status} ({len(traj.t) - 1} steps, {one.wall_time:.3g} s)")
    if traj.message:
        ctx.say(f"  {traj.message}")
    if one.no_reference:
        ctx.say(f"  no reference: {one.no_reference}")
    elif one.measured_at_end:
        ctx.say(f"  attitude error at t = {traj.t[-1]:g} s: {err[-1]:.3e} rad (against the {sc.reference} "
                f"reference); max over the grid {one.max_error:.3e} rad")
        ctx.say(f"  body-rate error at the end: {one.rate_error:.3e} rad/s")
    if csv:
        write_trajectory_csv(csv, f"{sc.name} / {method}, dt = {dt:g} s, status {traj.status}",
                             traj.t, traj.q, traj.omega, err, traj.extras.get("euler"))
        ctx.say(f"  trajectory: {csv}")
    if plot:
        from ..report.plots import run_figure

        run_figure(plot, f"{sc.name} / {method}, dt = {dt:g} s", traj, err)
        ctx.say(f"  plot: {plot}")
    return RunOutcome("PASSED" if one.ok else "FAILED", one)
