"""The report folder: ``results.json``, ``report.md``, an ``index.html`` (its plots linked from ``plots/``),
the figures as PNG and, when asked for (``--trajectories``), the finest runs' trajectories as CSV. Written into a hidden temporary folder and
renamed into place only when complete; ``latest`` then points at it."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ..base.files import (
    StampedFolder,
    trajectory_csv,
    write_bytes_atomic,
    write_json_atomic,
    write_text_atomic,
)
from ..base.pool import resolved, stop_pool
from ..results import outcome_of
from ..study.statements import accurate_text, flip_rows, invariants_text, precession_rows, usual_place, where_text
from ..trajectory import step_label
from ..versions import machine, versions
from .document import Cell, Contents, Figure, Heading, Para, Table, Verdict, to_html, to_markdown

__all__ = ["write_report", "draw_figures", "report_document", "report_results", "with_sections", "Section",
           "StampedFolder", "REPORT_SCHEMA", "verdict_of", "fmt"]

REPORT_SCHEMA = "xcheck.report/1"


def verdict_of(data: dict, method: str) -> str:
    """``pass`` | ``fail`` | ``expected`` | ``info`` for one method of a study's JSON (computed by the study)."""
    return data["methods"][method]["verdict"]


def fmt(x, spec=".2e") -> str:
    """A number of a report's table (``—`` for none)."""
    return "—" if x is None else format(x, spec)


# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Section:
    """More of the report than its scenarios' studies, typed: ``blocks`` placed before the appendix with their
    ``figures`` ``[(file, caption, png)]``, the keys it adds to ``results.json`` (``results``), whether it passed
    (its verdict joins the report's) and an optional sentence for the first screen (``summary``). The
    determination studies and seed 002 are one; ``xcheck nightly``'s History is another."""

    blocks: list
    figures: list = dataclasses.field(default_factory=list)
    results: dict = dataclasses.field(default_factory=dict)
    passed: bool = True
    summary: str | None = None


def report_results(studies, *, quick: bool = False, wall_time=None, throughput=None) -> dict:
    """The results document of ``studies`` (schema ``xcheck.report/1``) before any :class:`Section` joins it."""
    return {"schema": REPORT_SCHEMA, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "quick": quick, "versions": versions(), "machine": machine(), "wall_time": wall_time,
            "passed": all(st.passed for st in studies), "outcome": outcome_of(st.outcome for st in studies),
            "scenarios": [st.data for st in studies],
            "throughput": throughput or []}


def with_sections(results: dict, sections) -> dict:
    """``results`` with every section's keys, in order, and its verdict joined (a new document)."""
    out = dict(results)
    for section in sections:
        out.update(section.results)
        out["passed"] = out["passed"] and section.passed
        out["outcome"] = outcome_of([out.get("outcome", "PASSED"), "PASSED" if section.passed else "FAILED"])
    return out


def write_report(studies, out_root, *, stamp: str | None = None, throughput=None, wall_time=None,
                 quick=False, pool=None, figures: dict | None = None, trajectories: bool = False,
                 marks: list | None = None, sections=(), document: dict | None = None) -> Path:
    """Write the report of ``studies`` (list of StudyResult) under ``out_root/<stamp>/`` atomically and
    point ``out_root/latest`` at it. Returns the report folder.

    Figures: ``figures`` maps a scenario to its :func:`~xcheck.report.plots.render_figures` result, or to a
    future of it (drawn in a worker while other studies ran); the others are drawn here, in ``pool`` when
    given. ``trajectories``: also the sampled finest run of every method as CSV
    (``trajectories/<scenario>/<method>.csv``, ~4 MB a scenario). ``marks``: a list to which ``(phase,
    time.perf_counter())`` pairs are appended (``xcheck report --timings``). ``sections``: more of the report
    (:class:`Section`), or a function that makes them from the finished, read-only results document (``xcheck
    nightly``'s History compares it with the history). ``document``: a dict that receives the results document
    written (``results.json``), for a caller that goes on with it (the nightly records it).

    The report is written into a hidden ``.incomplete-<stamp>-<host>-<pid>`` folder and renamed into place
    when complete: on any error or interrupt the workers are stopped first and the folder removed; a
    folder left by a killed run (its process gone) is removed by the next report into ``out_root``. Two
    reports finishing in the same second get distinct names (``<stamp>-2``)."""
    import time

    marks = [] if marks is None else marks
    figures = dict(figures or {})
    folder = StampedFolder(out_root, stamp=stamp, on_failure=lambda: stop_pool(pool) if pool is not None else None)
    with folder as tmp:
        for st in studies:
            if st.name not in figures:
                figures[st.name] = (pool.submit(draw_figures, st.data, st.series, quick) if pool is not None
                                    else draw_figures(st.data, st.series, quick))
        for name, files in _trajectory_files(studies, pool).items() if trajectories else ():
            for file, text in resolved(files):
                write_bytes_atomic(tmp / "trajectories" / name / file, text)
        captions = {}
        for st in studies:
            drawn = resolved(figures[st.name])
            for file, _, png in drawn:
                write_bytes_atomic(tmp / "plots" / file, png)
            captions[st.name] = [(file, caption) for file, caption, _ in drawn]
        marks.append(("figures", time.perf_counter()))
        results = report_results(studies, quick=quick, wall_time=wall_time, throughput=throughput)
        if callable(sections):
            sections = sections(MappingProxyType(results))
        results = with_sections(results, sections)
        for section in sections:
            for file, _, png in section.figures:
                write_bytes_atomic(tmp / "plots" / file, png)
        write_json_atomic(tmp / "results.json", results)
        if document is not None:
            document.update(results)
        summary = next((sec.summary for sec in sections if sec.summary), None)
        document = report_document(studies, results, captions, extra=[b for sec in sections for b in sec.blocks],
                                   summary=summary)
        write_text_atomic(tmp / "report.md", to_markdown(document))
        write_text_atomic(tmp / "index.html", to_html(document, tmp / "plots", title="xcheck cross-check report"))
    marks.append(("files written", time.perf_counter()))
    return folder.final


def draw_figures(data: dict, series: dict, quick: bool = False) -> list[tuple[str, str, bytes]]:
    """:func:`xcheck.report.plots.render_figures`, importing matplotlib only where it runs (a worker)."""
    from .plots import render_figures

    return render_figures(data, series, quick=quick)


def trajectory_files(name: str, series: dict) -> list[tuple[str, bytes]]:
    """``--trajectories``: each method's sampled finest run of scenario ``name`` as CSV, ``[(file, UTF-8 bytes)]``."""
    return [(f"{method}.csv", trajectory_csv(
        f"{name} / {method}: the finest run (dt = {s['dt']:.6g} s), sampled every "
        f"{max(s['dt'], 1 / 256):.6g} s; q [w, x, y, z] body->world, body rates in body components; "
        "attitude error against the reference (empty where it is not defined)",
        s["t"], s["q"], s["omega"], s["attitude_error"], s.get("euler")).encode("utf-8"))
        for method, s in series.items()]


def _trajectory_files(studies, pool) -> dict:
    """Each study's :func:`trajectory_files` (the text or a future of it): with a pool, this process formats one
    scenario in (workers + 1) and the workers the others, which are idle by now (formatting the bundled quick report's
    512 files, 117 MB, took 6.8 s here alone)."""
    share = (getattr(pool, "_max_workers", 0) or 0) + 1
    jobs = {st.name: pool.submit(trajectory_files, st.name, st.series) for k, st in enumerate(studies)
            if pool is not None and k % share}
    return {st.name: jobs.get(st.name) or trajectory_files(st.name, st.series) for st in studies}


# ------------------------------------------------------------------------------------------------
# the report as one document (xcheck.report.document), written as Markdown and as HTML
# ------------------------------------------------------------------------------------------------
LEGEND = [("Each cell: the observed order · the attitude error [rad] at the finest step. ", None),
          ("pass", "mark"), (" every check passed; ", None), ("fail", "mark"), (" a check failed; ", None),
          ("expected", "mark"), (" an expected failure (the scenario's, or a known finding of an engine); ", None),
          ("inconclusive", "mark"), (" a check could not decide (no asymptotic range at these steps, a suspect or "
                                     "uncertain reference, nothing tested); ", None),
          ("info", "mark"), (" reported without checks.", None)]
#: The report's verdict line for each outcome.
VERDICTS = {"PASSED": ("PASSED: every check passed", "pass"), "FAILED": ("FAILED: some checks failed", "fail"),
            "INCONCLUSIVE": ("INCONCLUSIVE: no check failed, but some could not decide (each scenario says why)",
                             "inconclusive")}
#: A scenario's badge for each outcome.
BADGES = {"PASSED": ("passed", "pass"), "FAILED": ("FAILED", "fail"), "INCONCLUSIVE": ("INCONCLUSIVE", "inconclusive")}


def report_document(studies, results: dict, figures: dict, *, extra=(), summary: str | None = None) -> list:
    """The report's blocks: the verdict and the front table, one section per scenario, ``extra`` blocks, the
    appendix. ``results`` is the report's JSON (for its metadata), ``figures`` maps a scenario to its
    ``[(file, caption)]``; ``summary`` a sentence under the verdict."""
    outcome = results.get("outcome") or ("PASSED" if results["passed"] else "FAILED")
    when = f"Created {results['created']}" + (f" in {results['wall_time']:.1f} s" if results["wall_time"] else "")
    if results["quick"]:
        when += (" (quick: fewer steps; the final-error and invariant checks need the full range and are not "
                 "applied)")
    blocks = [Heading(1, "xcheck cross-check report"),
              Verdict(*VERDICTS[outcome]),
              *([Para([(summary, "b")])] if summary else []),
              Para(LEGEND, small=True)]
    methods = []
    for st in studies:
        methods += [m for m in st.methods if m not in methods]
    # methods down, scenarios across: a screen holds the whole matrix (18 methods x 6 scenarios, one line a cell)
    blocks.append(Table(["method"] + [st.name for st in studies],
                        [[Cell(m)] + [_front_cell(st, m) for st in studies] for m in methods],
                        header_links=[None] + [st.name for st in studies], compact=True))
    # when and with what, under the matrix: the first screen holds the verdict and the whole matrix (29 methods)
    blocks.append(Para(when + ". Versions: " + ", ".join(f"{k} {v}" for k, v in results["versions"].items()) +
                       f". Machine: {results['machine']['platform']}, {results['machine']['cpus']} CPUs.", small=True))
    blocks.append(Heading(2, "In words", anchor="in-words"))
    for st in studies:
        blocks.append(Para([(f"{st.name}: ", "b"), *_answer_runs(st), (scenario_summary(st), None)]))
    blocks.append(Contents([(st.name, st.name, BADGES[st.outcome][1]) for st in studies]
                           + [(h.text, h.anchor, "") for h in extra if isinstance(h, Heading) and h.anchor]
                           + [("Appendix: versions, machine, throughput", "appendix", "")]))
    for st in studies:
        blocks += _scenario_blocks(st, figures.get(st.name, []))
    blocks += list(extra)
    blocks += _appendix_blocks(results)
    return blocks


def _ms(seconds) -> str:
    return "—" if seconds is None else (f"{seconds * 1e3:.2g} ms" if seconds < 1 else f"{seconds:.3g} s")


def _step_text(w) -> str:
    """A :class:`~xcheck.metrics.StepWithin` in words: ``≈ 0.0271 s`` (interpolated), ``≥ 1/2`` (the coarsest
    tested step is within), ``—`` (not reached); an adaptive method's tolerance: ``rtol ≈ 3.2e-07``, ``rtol ≥
    1e-03``."""
    if not w.reached:
        return "—"
    if w.rtol is not None:
        return f"rtol ≈ {w.rtol:.2g}" if w.how == "interpolated" else f"rtol ≥ {w.rtol:.0e}"
    return f"≈ {w.dt:.3g} s" if w.how == "interpolated" else f"≥ {step_label(w.dt)} s"


def _at(w) -> str:
    """``at Δt ≈ 0.0271 s`` or, for an adaptive method, ``at rtol ≈ 3.2e-07``."""
    return f"at {_step_text(w)}" if w.rtol is not None else f"at Δt {_step_text(w)}"


def recommendation(st, key: str = "1e-06") -> list[str]:
    """The first screen's advice: the cheapest method within ``key`` rad over the run (by the wall time of one
    run at the largest step, or loosest tolerance, that keeps it there), then the cheapest of the other engine.
    Never a demonstration (a method kept to show a seed's misprint) or a failure the scenario expects; where a
    demonstration would have been cheaper, the sentence says why it is not advised."""
    from ..runners import RUNNERS

    def demo(m):
        return RUNNERS[m.name].demonstration if m.name in RUNNERS else None

    reach = [(m.within[key].wall_time, m) for m in st.methods.values()
             if key in m.within and m.within[key].reached and m.within[key].wall_time is not None
             and m.verdict != "expected"]
    advised = [(w, m) for w, m in reach if not demo(m)]
    tol = key.replace("e-0", "e-")
    out = []
    if not advised:
        return [f"No method stays within {tol} rad at the tested steps."]
    wall, best = min(advised, key=lambda x: x[0])
    out.append(f"Cheapest to {tol} rad over the run: {best.name} {_at(best.within[key])} ({_ms(wall)} a run).")
    cheaper = [(w, m) for w, m in reach if demo(m) and w < wall]
    if cheaper:
        w0, m0 = min(cheaper, key=lambda x: x[0])
        out.append(f"({m0.name} would take {_ms(w0)} but is not advised: it is {demo(m0)}.)")
    for engine in dict.fromkeys(["xcheck", "mujoco", *(m.engine for _, m in advised)]):  # ours, MuJoCo, the others
        if engine == best.engine:
            continue
        theirs = [(w, m) for w, m in advised if m.engine == engine]
        if theirs:
            w2, other = min(theirs, key=lambda x: x[0])
            out.append(f"Cheapest {'of ours' if engine == 'xcheck' else 'in ' + engine}: {other.name} "
                       f"{_at(other.within[key])} ({_ms(w2)}, {w2 / wall:.2g}× the time).")
    missing = [m.name for m in st.methods.values() if m.engine != "xcheck" and m.name not in
               {n.name for _, n in reach}]
    if missing:
        out.append(f"Not within {tol} rad at any tested step or tolerance: {', '.join(missing)}.")
    return out


def scenario_summary(st) -> str:
    """What a scenario's numbers say, in a few sentences: the cheapest way to 1e-6 rad (ours and the engines';
    :func:`recommendation`), how the engines' integrators compare with ours trajectory against trajectory, and
    the methods whose observed order is not their theory."""
    out = recommendation(st)
    pairs = {}
    for c in st.comparisons:  # the finest step of each pair
        if (c["a"], c["b"]) not in pairs or c["dt"] < pairs[(c["a"], c["b"])]["dt"]:
            pairs[(c["a"], c["b"])] = c
    by_partner = {}
    for (a, b), c in pairs.items():
        by_partner.setdefault((b, c["dt"]), []).append(f"{a} {c['max_attitude_difference']:.2g} rad")
    for (b, dt), items in by_partner.items():
        out.append(f"Trajectory against trajectory (no reference), largest difference from {b} over the run at "
                   f"Δt = {step_label(dt)} s: {', '.join(items)}.")
    off = [m for m in st.methods.values() if m.expected_order is not None and m.verdict == "fail"
           and any(c.kind == "order" and c.method == m.name and not c.passed for c in st.checks)]
    if off:
        out.append("Observed order not its theory: " + ", ".join(
            f"{m.name} ({fmt(m.observed_order, '.2f')}, expected {m.expected_order})" for m in off) + ".")
    elif any(m.observed_order is not None for m in st.methods.values()):
        out.append("Every measured order matches its theory" +
                   (" (the expected failures aside)." if any(m.verdict == "expected" for m in st.methods.values())
                    else "."))
    known = [c.name for c in st.checks if c.known and not c.left_out]
    if known:
        out.append(f"Explained by known findings of their engines: {', '.join(known)}.")
    early = [c.method for c in st.checks if c.left_out]
    if early:
        out.append(f"Left out of the verdict, pre-asymptotic at these steps (xcheck's own): {', '.join(early)}.")
    undecided = [c for c in st.checks if c.inconclusive]
    if undecided:  # what the study could not decide, and what would (issue 36)
        out.append("Could not decide: " + "; ".join(f"{c.name} ({c.note.rsplit('; ', 1)[-1]})" for c in undecided[:3])
                   + (f"; and {len(undecided) - 3} more" if len(undecided) > 3 else "") + ".")
    out += [f"Inconclusive: {why}." for why in st.inconclusive]
    return " ".join(out)


def _front_cell(st, name) -> Cell:
    m = st.methods.get(name)
    if m is None:
        return Cell()
    finest = m.finest
    text = f"{m.observed_order:.2f}" if m.observed_order is not None else (m.status if m.status != "ok" else "—")
    return Cell(f"{text} · {fmt(finest.attitude_error if finest else None, '.1e')}", m.verdict)


def _motion_blocks(table, headers, formats) -> list:
    """A motion table (:func:`~xcheck.study.statements.flip_rows`' or ``precession_rows``' ``(head, rows)``): its
    sentence and its table, ``formats`` one per value after the method and its step ("—" for None)."""
    if table is None:
        return []
    head, rows = table
    cells = [[name, at, *(Cell("—" if v is None else f"{v:{f}}", num=True) for v, f in zip(values, formats))]
             for name, at, *values in rows]
    return [Para(head[0].upper() + head[1:] + ".", small=True), Table(["method", "at", *headers], cells)]


def _flip_blocks(st) -> list:
    """A tumbling body's flips per method (:func:`~xcheck.study.statements.flip_rows`): the sentence and the table."""
    return _motion_blocks(flip_rows(st), ["flips", "first [s]", "Δ first [s]", "every [s]", "Δ every [s]"],
                          ["d", ".6g", "+.1e", ".6g", "+.1e"])


def _precession_blocks(st) -> list:
    """A top's or an axisymmetric body's cone per method (:func:`~xcheck.study.statements.precession_rows`)."""
    return _motion_blocks(precession_rows(st), ["precession [rad/s]", "Δ [rad/s]", "nutation period [s]", "Δ [s]",
                                                "cone Δ [rad]"], [".7g", "+.1e", ".7g", "+.1e", "+.1e"])


def _built_blocks(st) -> list:
    """What each engine was given for the body (:mod:`xcheck.engines.built`), a line per engine."""
    from ..engines.built import ENGINE_NAMES

    if not st.built:
        return []
    return [Para([("What each engine was given", "b"), (f" ({st.built['body']}): ", None),
                  ("; ".join(f"{ENGINE_NAMES.get(e, e)}: {text}" for e, text in st.built["engines"].items()) + ".",
                   None)], small=True)]


def _advice_blocks(st) -> list:
    """What to use instead (:mod:`xcheck.study.advice`): a sentence, then a line per engine, what to write as code."""
    from ..study.advice import advice_parts

    parts = advice_parts(st)
    if not parts:
        return []
    return [Para([("What to use instead:", "b"), (" per engine, the cheapest of its integrators at the largest step "
                                                   "this study ran that keeps the tolerance over the run (there and at "
                                                   "every finer step).", None)], small=True),
            *(Para([(f"{who}: ", None), *([(use, "code"), (f" ({rest})", None)] if use else [(rest, None)])])
              for who, use, rest in parts)]


def _statement_cells(m, usual: str | None) -> list:
    """A method's two statements and its invariants at the step its accuracy is judged at (the step said where it
    is not ``usual``, the step of most rows), as table cells."""
    a = m.accurate
    consistent = {"yes": "pass", "no": "fail", "known finding": "expected", "pre-asymptotic": "expected",
                  "expected to fail": "expected"}
    accurate = accurate_text(a, show_step=a is not None and where_text(a) != usual)
    return [Cell(m.consistent, consistent.get(m.consistent, "")),
            Cell(accurate, "" if a is None else "pass" if a["within"] else "fail"),
            *(Cell(text, num=True) for text in invariants_text(a))]


def _answer_runs(st) -> list:
    """The answer at the user's step as the text runs that lead a scenario's words (none without a step of theirs)."""
    from ..study.your_step import answer_line

    line = answer_line(st.your_step)
    return [("A" + line[1:] + ". ", "b")] if line else []


def _scenario_blocks(st, figs) -> list:
    from ..study import engine_said_lines, finer_lines, left_out_lines

    sc = st.scenario
    blocks = [Heading(2, sc.name, anchor=sc.name, badge=BADGES[st.outcome])]
    if st.your_step:  # the user's question first: at their step, over their run (issue 59)
        blocks.append(Para(_answer_runs(st)))
    if sc.description:
        blocks.append(Para(sc.description))
    if sc.assumptions:  # a scenario made from an MJCF file alone: what xcheck assumed, in words
        blocks.append(Para([("Assumed from the MJCF alone (xcheck init writes them into a scenario file to edit): ",
                             "b"), ("; ".join(sc.assumptions) + ".", None)]))
    q0 = (np.round(sc.q0, 6) + 0.0).tolist()
    w0 = (np.round(sc.omega0, 6) + 0.0).tolist()
    blocks.append(Para([("Model ", None), (str(sc.model), "code"), (f", {sc.duration:g} s, reference ", None),
                        (sc.reference, "b"), (f"; q0 = {q0} (body → world), ω0 = {w0} rad/s (body frame); torque: "
                                              f"{_torque_text(sc.torque)}{_own_torque_text(st.data)}. Orders "
                                              f"are measured on errors above {st.order_floor:.2g} rad.", None)],
                       small=True))
    if st.reference_check:  # what the guard found: the closed form checked, or DOP853 instead and why
        blocks.append(Para([("Reference: ", "b"), (st.reference_check["text"][0].upper() + st.reference_check["text"][1:]
                                                    + ".", None)], small=True))
    for why in st.inconclusive:  # what the study cannot decide, beyond its checks' notes
        blocks.append(Para([("Inconclusive: ", "b"), (why + ".", None)]))
    blocks += [Figure(file, caption) for file, caption in figs]  # the figures first, then the tables behind them
    rows = []
    for c in st.checks:
        cls = "expected" if c.known or (c.passed and c.kind == "expected-failure") else "pass" if c.passed else c.status
        unit = CHECK_UNITS.get(c.kind, "")
        rows.append([c.name, Cell({"pass": "pass", "fail": "FAIL", "inconclusive": "INCONCLUSIVE",
                                   "known": "KNOWN"}[c.status], cls),
                     Cell(fmt(c.value, ".3g") + (unit if c.value is not None else ""), num=True),
                     Cell(fmt(c.limit, ".3g") + (unit if c.limit is not None else ""), num=True),
                     c.note + (f"; {c.known}" if c.known else "")])
    failed = sum(c.failed for c in st.checks)
    undecided = sum(c.inconclusive for c in st.checks)
    known = sum(bool(c.known) for c in st.checks)
    blocks.append(Table(["check", "result", "value", "limit", "note"], rows,
                        fold=f"{len(st.checks)} checks, {failed} failed" + (f", {undecided} inconclusive" if undecided
                                                                           else "")
                        + (f", {known} known findings" if known else "")
                        + (" (shown)" if failed or undecided else " (click to show)")))
    rows = []
    fixed = {n: m for n, m in st.methods.items() if not m.adaptive}
    usual = usual_place(fixed.values())
    adaptive = {n: m for n, m in st.methods.items() if m.adaptive}
    for name, m in fixed.items():
        by_dt = {r.dt: r for r in m.runs}
        rates = [r.steps_per_second for r in m.runs if r.steps_per_second]
        left, why = st.over_budget.get(name, ((), ""))
        rows.append([Cell(name, m.verdict), "adaptive" if m.expected_order is None else str(m.expected_order),
                     Cell(fmt(m.observed_order, ".2f"), num=True),
                     *(Cell("—", title=f"not run: {why}") if d in left else _run_cell(by_dt.get(d)) for d in st.steps),
                     Cell(f"{max(rates):.3g}" if rates else "", num=True), *_statement_cells(m, usual)])
    yours = st.your_step["dt"] if st.your_step and st.your_step["studied"] else None
    at = f"at {step_label(yours)} s" if yours else "at its finest step"
    tol = next((m.accurate["tolerance"] for m in fixed.values() if m.accurate), None)
    blocks.append(Para("Every method's attitude error [rad] at the end of the run, at each step Δt [s]; the "
                       "orders expected and observed; its best speed [steps/s]. Then its two statements: consistent "
                       "(the order and invariants its theory gives) and accurate (its largest attitude error over the "
                       f"run within {fmt(tol, 'g')} rad {at}), and the invariants there: the energy's and |L|'s largest "
                       "relative change over the run (+ gained, − damped) and its growth, the angle [rad] L's "
                       "direction turned.", small=True))
    blocks.append(Table(["method", "expected", "observed",
                         *(f"{step_label(d)} s" + (" (yours)" if d == yours else "") for d in st.steps), "steps/s",
                         "consistent", f"accurate {at}", "energy", "|L|", "L turned"], rows))
    blocks += _flip_blocks(st) + _precession_blocks(st) + _advice_blocks(st) + _built_blocks(st)
    if adaptive:
        tols = sorted({r.rtol for m in adaptive.values() for r in m.runs}, reverse=True)
        out_step = step_label(next(iter(adaptive.values())).runs[0].dt)
        blocks.append(Para(f"Adaptive methods at their own relative tolerances (the absolute in each method's own "
                           f"proportion), compared with the reference every {out_step} s: the attitude error at the "
                           "end; the work is the right-hand-side evaluations of the tightest run (— where the engine "
                           "does not report them).", small=True))
        rows = []
        for name, m in adaptive.items():
            by_tol = {r.rtol: r for r in m.runs}
            tight = m.finest
            rows.append([Cell(name, m.verdict), *(_run_cell(by_tol.get(t)) for t in tols),
                         Cell(f"{tight.evaluations:,}" if tight and tight.evaluations else "—", num=True)])
        blocks.append(Table(["method", *(f"rtol {t:.0e}" for t in tols), "evaluations"], rows))
    for line in left_out_lines(st):  # never a silent gap
        blocks.append(Para([("Left out: ", "b"), (line + ".", None)], small=True))
    for line in finer_lines(st):  # steps the study added
        blocks.append(Para([("Added: ", "b"), (line + ".", None)], small=True))
    for line in engine_said_lines(st):  # an engine's own warnings, caught (base.captured)
        blocks.append(Para([("An engine said: ", "b"), (line, None)], small=True))
    blocks += _file_blocks(st)
    keys = [k for k in ("1e-03", "1e-06", "1e-09")]
    blocks.append(Para("What a tolerance costs: the largest step at which each method stays within it over the "
                       "whole run (≈ interpolated on the log-log line between the two tested steps that bracket it; "
                       "≥ the coarsest tested step already is; — not even the finest is), and the wall time of one "
                       "run at that step; for an adaptive method, the loosest of its tolerances that does.",
                       small=True))
    rows = []
    for name, m in st.methods.items():
        rows.append([Cell(name, m.verdict)] + [Cell(f"{_step_text(m.within[k])} · {_ms(m.within[k].wall_time)}"
                                                     if k in m.within and m.within[k].reached else "—", num=True)
                                                for k in keys])
    blocks.append(Table(["method", *(f"within {k} rad" for k in keys)], rows))
    blocks += engines_compared(st)
    return blocks


def _file_blocks(st) -> list:
    """Issue 39: the scenario's trajectory files, each a row beside the methods: how it was read, its largest errors
    against the reference, how its error grows, the invariants from its samples, its verdict and the detective's
    word."""
    if not st.files:
        return []
    rows = []
    for name, f in st.files.items():
        cls = "pass" if f.passed else ("expected" if name in st.scenario.checks["expected_to_fail"] else "fail")
        drift = "—" if f.energy_change is None else f"{f.energy_change:+.1e} / {f.momentum_change:+.1e}"
        rows.append([Cell(name, cls), f"{f.rows:,}", Cell(fmt(f.max_attitude_error, ".2e"), num=True),
                     Cell(fmt(f.max_rate_error, ".2e"), num=True),
                     Cell("—" if f.growth is None else f"t^{f.growth:.2f}", num=True), Cell(drift, num=True),
                     Cell(f.outcome, cls)])
    blocks = [Para("Trajectory files of other simulators, each one run scored against the same reference (no "
                   "order): the largest attitude error [rad] and body-rate error [rad/s] over the run, the growth "
                   "of the attitude error (the exponent p of t^p over the last nine tenths), and the largest "
                   "relative change of the energy and of the angular momentum's magnitude |L| computed from the file's "
                   "own samples (+ gained, − damped).", small=True),
              Table(["file", "rows", "attitude", "rate", "growth", "energy / |L|", "verdict"], rows)]
    for name, f in st.files.items():
        read = f"{name}: read as {f.convention}" + (f"; source: {f.source}" if f.source else "")
        blocks.append(Para([(f.sentence() + ". ", None), (read + ".", None)]
                           + [(" " + n + ".", None) for n in f.notes], small=True))
    return blocks


def _own_torque_text(data: dict) -> str:
    """What the model itself exerts (a top's gravity, a gyrostat's wheels), as words after the scenario's torque."""
    return f"; the model's own: {data['model_torque']}" if data.get("model_torque") else ""


def _torque_text(torque) -> str:
    """A scenario's torque in words, with units and frames (a sum's terms joined by +)."""
    if isinstance(torque, list):
        return " + ".join(_torque_text(term) for term in torque) or "none"
    if not torque:
        return "none"
    if torque.get("kind") == "constant":
        return f"constant {torque['torque']} N·m (body frame)"
    if torque.get("kind") == "gravity-gradient":
        orbit = ", ".join(f"{k} = {v}" for k, v in torque.items() if k != "kind")
        return "gravity gradient, 3 μ/r³ (o × I o) along a circular orbit" + (f" ({orbit})" if orbit else " (RAX-1's)")
    if torque.get("kind") in ("solar-pressure", "aerodynamic"):
        keys = ", ".join(f"{k} = {v}" for k, v in torque.items() if k != "kind")
        return f"{torque['kind']} force through a centre of pressure ({keys}; the rest the model's defaults)"
    rest = ", ".join(f"{k} = {v}" for k, v in torque.items() if k not in ("kind", "field", "dipole"))
    dipole = f", dipole {torque['dipole']} A·m² (body frame)" if "dipole" in torque else ", the MJCF's dipole"
    return f"magnetic, field {torque.get('field')}" + dipole + (f" ({rest})" if rest else "")


#: The unit of a check's value and limit, by kind (an order has none; the drift of an invariant is relative).
CHECK_UNITS = {"final-error": " rad", "agreement": " rad", "invariants": " (relative)"}


def _run_cell(r) -> Cell:
    if r is None:
        return Cell()
    if not r.ok:
        return Cell(r.status, "fail", title=r.message)
    return Cell(f"{r.attitude_error:.1e}", num=True)


def engines_compared(st) -> list:
    """"Engines compared" (when a study has methods of two engines): at each step each engine's RK4 and its most
    accurate method, and which engine is closest to the reference; then why, from each engine method's twin
    among ours (the same scheme: their difference is the engine's own), the order its input allows, and the
    steps its clock rounds."""
    from ..runners import RUNNERS

    engines = {}
    for m in st.methods.values():
        if m.engine != "xcheck":
            engines.setdefault(m.engine, []).append(m)
    if len(engines) < 2:
        return []

    def error(name, d):
        m = st.methods.get(name)
        r = next((r for r in m.runs if r.dt == d and r.rtol is None and r.ok and r.attitude_error), None) if m else None
        return r.attitude_error if r else None

    rk4 = [f"{e}-rk4" for e in engines if f"{e}-rk4" in st.methods]
    rows = []
    for d in st.steps:
        errs = {n: error(n, d) for n in rk4}
        best = {}
        for engine, ms in engines.items():
            got = [(error(m.name, d), m.name) for m in ms if error(m.name, d) is not None]
            best[engine] = min(got) if got else None
        win4 = min((n for n in errs if errs[n] is not None), key=lambda n: errs[n], default=None)
        win = min((e for e in best if best[e] is not None), key=lambda e: best[e][0], default=None)
        rows.append([step_label(d)]
                    + [Cell(fmt(errs[n], ".1e"), "pass" if n == win4 else "", num=True) for n in rk4]
                    + [Cell("—" if b is None else f"{b[1]} {b[0]:.1e}", "pass" if e == win else "", num=True)
                       for e, b in best.items()] + [win or "—"])
    why = []
    pairs = {}
    for c in st.comparisons:
        pairs.setdefault((c["a"], c["b"]), []).append(c["max_attitude_difference"])
    same = []
    for ms in engines.values():
        for m in ms:
            runner = RUNNERS[m.name]
            diffs = pairs.get((m.name, runner.twin))
            reason = runner.order_for(st.scenario.torque, st.scenario.model)[1]
            if diffs:
                twin = RUNNERS[runner.twin]
                if reason is None:
                    same.append(m.name)
                    why.append(f"{m.name} and {runner.twin} ({twin.summary}) differ by at most {max(diffs):.1g} rad "
                               f"at every step: the same method, so {m.name}'s error is that scheme's.")
                else:
                    why.append(f"{m.name} differs from {runner.twin} ({twin.summary}) by up to {max(diffs):.1g} rad: "
                               f"{reason}.")
            elif reason:
                why.append(f"{m.name}: {reason}.")
            rounded = sorted({r.dt for r in m.runs if r.ok and r.message})
            if rounded and m.name in rk4:
                why.append(f"{m.engine.capitalize()} cannot run Δt = {', '.join(step_label(d) for d in rounded)} s in "
                           "whole nanoseconds of its clock: those runs are compared with the reference at its own "
                           "(rounded) times, not reported as an error.")
    if len(same) >= 2:
        common = [d for d in st.steps if all(error(n, d) for n in same)]
        if common:
            d = common[len(common) // 2]
            errs = sorted((error(n, d), n) for n in same)
            ratio = errs[-1][0] / errs[0][0]
            if ratio > 10:
                why.append(f"So the engines' RK4s differ as their schemes do: at Δt = {step_label(d)} s {errs[-1][1]}'s "
                           f"error is {ratio:.2g}× {errs[0][1]}'s. Here the body turns at {np.linalg.norm(st.scenario.omega0):.3g} "
                           "rad/s: RK4 follows the curved path of the attitude coordinates it integrates with an error "
                           "that grows with the angle turned per step, while RK4 on the exponential map (MuJoCo's free "
                           "joint, lie-rkmk4) integrates a rotation at constant rate exactly and errs only by the rate's "
                           "change.")
    return [Heading(3, "Engines compared", anchor=f"{st.name}-engines"),
            Para("Each engine's RK4 and its most accurate method at each step, against the reference; the closest "
                 "marked."),
            Table(["Δt [s]", *rk4, *(f"{e}: most accurate" for e in engines), "closest engine"], rows),
            *([Para(" ".join(why))] if why else [])]


def _appendix_blocks(results) -> list:
    m = results["machine"]
    blocks = [Heading(2, "Appendix: versions, machine, throughput", anchor="appendix"),
              Para("Versions: " + ", ".join(f"{k} {v}" for k, v in results["versions"].items()) +
                   f". Machine: {m['platform']}, {m['processor']}, {m['cpus']} CPUs."),
              Para("Steps per second (batch: body-steps per second)." if results["throughput"] else
                   "No throughput measured.", small=True)]
    if results["throughput"]:
        blocks.append(Table(["engine", "method", "scenario", "batch", "steps/s"],
                            [[r["engine"], r["method"], r["scenario"], Cell(str(r["batch"]), num=True),
                              Cell(f"{r['steps_per_second']:.3g}", num=True)] for r in results["throughput"]]))
    return blocks
