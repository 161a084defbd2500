"""The report as a piece of work (``xcheck report``, and the first half of ``xcheck nightly``): the scenarios'
studies, their determination studies and figures in one pool of workers, then the report folder. Typed in,
typed out: :func:`build_report` returns a :class:`ReportOutcome`; the command line prints it and chooses the
exit code.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import Future
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Callable

from ..base.pool import resolved
from ..study.executor import worker_modules
from .render import Section, draw_figures, with_sections

__all__ = ["ReportOutcome", "build_report", "resolve_scenarios"]


def resolve_scenarios(names, resolve=None) -> list:
    """The scenarios named (every bundled one when none is), every input error before any work, and distinct
    names (they name a report's files): :class:`~xcheck.scenario.ScenarioError` otherwise. ``resolve(name)``: how a
    name becomes a scenario (default :func:`~xcheck.scenario.resolve_scenario`)."""
    from ..scenario import ScenarioError, bundled_scenarios, resolve_scenario

    scenarios = [(resolve or resolve_scenario)(n) for n in names or list(bundled_scenarios())]
    first = {}
    for sc in scenarios:
        if sc.name in first:
            raise ScenarioError(f"two scenarios are named {sc.name!r} ({first[sc.name]} and {sc.path}): a report "
                                "needs distinct names (they name its files)")
        first[sc.name] = sc.path
    return scenarios


@dataclass
class ReportOutcome:
    """What :func:`build_report` did: the studies (in the scenarios' order), the report folder, whether every built-in
    section passed (:data:`BUILT_IN`: the determination studies with seed 002's tables, the league; True when none is
    in the report), the phases' ``(name, time.perf_counter())`` marks (``--timings``), and the results document
    written (``results.json``)."""

    studies: list
    folder: Path
    sections_passed: bool = True
    marks: list = field(default_factory=list)
    document: dict = field(default_factory=dict)  # the report's results.json, as written

    @property
    def outcome(self) -> str:
        """The report's outcome (:func:`xcheck.results.outcome_of` its studies' and sections')."""
        from ..results import outcome_of

        return outcome_of([st.outcome for st in self.studies] + ([] if self.sections_passed else ["FAILED"]))

    @property
    def passed(self) -> bool:
        return self.outcome == "PASSED"

    def timings(self) -> str:
        """``where the time went: phase 0.12 s, ...``."""
        return "where the time went: " + ", ".join(f"{what} {b - a:.2f} s" for (_, a), (what, b)
                                                   in zip(self.marks, self.marks[1:]))


def build_report(scenarios, out, *, quick: bool = False, workers: int | None = None, bench=None,
                 run_bench: bool = False, trajectories: bool = False, sections=None, progress=None,
                 written: Callable[[Path], None] | None = None, started: float | None = None,
                 horizons: bool = False) -> ReportOutcome:
    """The report of ``scenarios`` into ``out``: :class:`~xcheck.scenario.Scenario` objects, or the names and
    files to resolve (:func:`resolve_scenarios`: done while the workers start, as is the check of ``out``).

    ``workers``: 1 runs everything in this process; otherwise a pool of one worker fewer than ``workers`` (the
    CPU count by default) runs the studies and draws the figures beside this process. ``bench``: ``xcheck
    bench`` rows measured by the caller; else measured here when ``run_bench``. ``sections``: more of the
    report (:class:`~xcheck.report.render.Section`), or a function that makes them from the finished, read-only
    results document (the nightly's History), see :func:`xcheck.report.render.write_report`. ``written(folder)`` is
    called as soon as the folder is complete (an interrupt after it has a complete report). ``started``: the
    first mark (the command's start). ``horizons``: the horizon studies of the scenarios with a ``[horizon]`` table
    (:mod:`xcheck.report.horizons`), a section of their own."""
    from ..base.pool import worker_pool
    from .render import write_report

    t0 = time.perf_counter()
    marks = [("start", t0 if started is None else started), ("pool started", t0)]
    document: dict = {}  # the results document, filled as it is written
    # a pool of one worker fewer (this process runs studies too: each process pays 1-3 s of imports and
    # compiled-code loading), started first so that the workers import numpy, numba, MuJoCo, matplotlib (and
    # Basilisk) while this process imports its own
    size = max(1, (workers or os.cpu_count() or 2) - 1)
    with worker_pool(size, warm=worker_modules(figures=True)) if workers != 1 else nullcontext() as pool:
        from ..base.files import check_output_dir
        from ..scenario import Scenario
        from ..study import run_studies, throughput_rows

        if not scenarios or not all(isinstance(sc, Scenario) for sc in scenarios):  # none: every bundled one
            scenarios = resolve_scenarios(scenarios)
        check_output_dir(out, "--out")
        marks.append(("scenarios read", time.perf_counter()))
        figures = _Figures(pool, quick) if pool is not None else None
        begun = [(make, start(scenarios, pool, quick, progress)) for start, make in BUILT_IN  # beside the studies
                 if horizons or start is not _start_horizons]
        studies = run_studies(scenarios, quick=quick, progress=progress, pool=pool, workers=workers,
                              on_study=figures.submit if figures else None, here=pool is not None,
                              idle=figures.draw_one_here if figures else None)
        while figures and figures.draw_one_here():  # the workers draw the rest
            pass
        marks.append(("studies", time.perf_counter()))
        if bench is None and run_bench:
            from ..bench import run_bench as measure

            bench = measure(quick=quick, repeat=1)
        built = [section for make, work in begun if (section := make(work)) is not None]
        marks.append(("sections", time.perf_counter()))  # the horizons', when asked for, the longest
        folder = write_report(studies, out, throughput=throughput_rows(studies) + (bench or []),
                              wall_time=time.perf_counter() - t0, quick=quick, pool=pool,
                              figures=figures.futures if figures else None,
                              trajectories=trajectories, marks=marks,
                              sections=_all_sections(built, sections), document=document)
        if written is not None:
            written(folder)
    marks.append(("workers stopped", time.perf_counter()))
    return ReportOutcome(studies=studies, folder=folder, marks=marks, document=document,
                         sections_passed=all(section.passed for section in built))


class _Figures:
    """Each scenario's figures, drawn once its studies are in. They wait here (:meth:`submit`) while this process
    has studies of its own to run, so that none is queued before a worker's last runs (Basilisk's, the longest);
    then (:meth:`draw_one_here`) each worker is kept one figure ahead, taken from the front, and this process
    draws the others from the back: neither waits for the other, and the figures end within one of each other."""

    def __init__(self, pool, quick: bool):
        self.pool, self.quick = pool, quick
        self.futures: dict = {}  # scenario -> Future of draw_figures' result
        self._held: list = []  # scenarios whose figures are not yet drawn nor given to a worker
        self._jobs: dict = {}  # scenario -> (data, series)
        self._workers = getattr(pool, "_max_workers", 1) or 1
        self._open = False  # figures go to the workers once this process has run out of studies

    def submit(self, study) -> None:
        self._jobs[study.name] = (study.data, study.series)
        self._held.append(study.name)
        self._feed()

    def _feed(self) -> None:
        if not self._open:
            return
        busy = sum(not f.done() for f in self.futures.values())
        while self._held and busy < self._workers + 1:  # each worker drawing one, one queued behind it
            name = self._held.pop(0)
            self.futures[name] = self.pool.submit(draw_figures, *self._jobs[name], self.quick)
            busy += 1

    def draw_one_here(self) -> bool:
        """Draw the latest scenario's figures here; whether there was one (none: the workers have the rest)."""
        self._open = True
        self._feed()
        if not self._held:
            return False
        name = self._held.pop()
        drawn = Future()
        drawn.set_result(draw_figures(*self._jobs[name], self.quick))
        self.futures[name] = drawn
        self._feed()
        return True


def _start_determinations(scenarios, pool, quick: bool, progress=None) -> dict:
    """Each scenario's ``[determination]`` study with its figures, started in the pool (or run here)."""
    from .determination import determination_job

    return {sc.name: pool.submit(determination_job, sc) if pool is not None else determination_job(sc)
            for sc in scenarios if sc.determination is not None}


def determination_section(determinations) -> Section:
    """The determination studies (each ``(data, figures)``, or a future of it) and seed 002 reproduced, as one
    :class:`~xcheck.report.render.Section`: its verdict joins the report's."""
    from ..determination.seed002 import reproduce
    from .determination import determination_blocks, seed002_blocks

    blocks, figures, data = [], [], []
    for future in determinations:
        one, drawn = resolved(future)
        data.append(one)
        blocks += determination_blocks(one, [(file, caption) for file, caption, _ in drawn])
        figures += drawn
    rep = reproduce()
    blocks += seed002_blocks(rep)
    return Section(blocks=blocks, figures=figures, results={"determination": data, "seed002": {"passed": rep["passed"]}},
                   passed=rep["passed"] and all(d["passed"] for d in data))


def _start_league(scenarios, pool, quick: bool, progress=None):
    """The boxes benchmark's league rows, started in the pool (or run here) when a bundled boxes scenario is in the
    report: ``(steps, [future or rows])``; None otherwise."""
    from ..league.boxes import CASES
    from ..league.run import QUICK_STEPS, REPORT_STEPS, league_tasks, mujoco_rows
    from ..paths import BUNDLED_MODELS

    bundled = {(BUNDLED_MODELS / "scenarios" / f"{c.scenario}.toml").resolve() for c in CASES.values()}
    if not any(Path(sc.path).resolve() in bundled for sc in scenarios):
        return None
    steps = QUICK_STEPS if quick else REPORT_STEPS
    # MuJoCo's runs in the workers; ours here, after the studies (a Basilisk worker never loads compiled code)
    return steps, [pool.submit(fn, *args) if pool is not None and fn is mujoco_rows else (fn, *args)
                   for fn, *args in league_tasks(steps=steps)]


def _determination_section(started: dict) -> Section | None:
    return determination_section(started.values()) if started else None


def _league_section(league) -> Section | None:
    if league is None:
        return None
    from ..league.table import section

    steps, parts = league
    return section([r for part in parts for r in (part.result() if hasattr(part, "result") else part[0](*part[1:]))],
                   steps)


def _start_horizons(scenarios, pool, quick: bool, progress=None) -> tuple:
    """The ``[horizon]`` scenarios' horizon studies: run once the studies are in, in the pool and here
    (:func:`xcheck.report.horizons.start_horizons`)."""
    from .horizons import start_horizons

    return start_horizons(scenarios, pool, progress)


def _horizon_section(started: list):
    from .horizons import horizon_section

    return horizon_section(started) if started[0] else None


#: The report's built-in sections, in their order: ``(start, make)`` — ``start(scenarios, pool, quick, progress)`` submits
#: their work beside the studies (None where no scenario asks for it), ``make(work)`` is the
#: :class:`~xcheck.report.render.Section` once it is in (None: not in this report). Every section's verdict joins the
#: report's by the one rule of :attr:`ReportOutcome.outcome`; a new one is an entry here.
BUILT_IN = ((_start_horizons, _horizon_section), (_start_determinations, _determination_section),
            (_start_league, _league_section))


def _all_sections(first, sections):
    """The report's sections: ``first``'s (the determination studies', when any scenario has a ``[determination]``;
    the league table's, when a bundled boxes scenario is reported; Nones left out), then ``sections``' own (the
    nightly's History: a function of the read-only results document, which sees the first ones' keys)."""
    first = [f for f in first if f is not None]
    if not first:
        return sections or ()
    if not callable(sections):
        return [*first, *(sections or ())]

    def made(results):
        return [*first, *sections(MappingProxyType(with_sections(dict(results), first)))]
    return made
