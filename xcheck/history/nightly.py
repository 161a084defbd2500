"""``xcheck nightly``: the full report, compared with the history's previous run and rolling baseline, then
recorded in it (issue 11). The storage and the comparison rules are :mod:`xcheck.history.store`'s; the History
section's figures and tables :mod:`xcheck.report.trends`'; the MuJoCo version matrix :mod:`xcheck.history.matrix`'s.

A run's **series** is what it is compared with: runs of the same kind (quick or full) in the same environment
(the one xcheck runs in, or one MuJoCo version of the matrix). A new MuJoCo release installed between two
nights stays in the series: catching what it changed is the point.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import store as H

#: Stored runs drawn in the History section's trend plots (the newest; the history keeps every run).
TREND_RUNS = 60


def default_history(out) -> Path:
    return Path(out) / "history.sqlite"


def host_name() -> str:
    return socket.gethostname() or "unknown"


def git_commit() -> str | None:
    """The project's commit when xcheck runs from a git checkout (``+dirty`` with uncommitted changes to
    tracked files), else None."""
    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        return None
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10)
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    if head.returncode != 0:
        return None
    return head.stdout.strip() + ("+dirty" if dirty.returncode == 0 and dirty.stdout.strip() else "")


def check_history(location, baseline: int | None = None) -> None:
    """Before any work: the history can be used (an existing one is read whole and found writable, nothing
    written) and ``--baseline`` names one of its runs. :class:`~xcheck.history.HistoryError` otherwise."""
    if not H.is_url(location) and not Path(location).exists():
        H.check_new(location)
        if baseline is not None:
            raise H.HistoryError(f"--baseline {baseline}: the history {location} does not exist yet")
        return
    with H.open_history(location, read_only=True) as hist:
        hist.check()
        ids = [r["id"] for r in hist.runs()]
        if baseline is not None and baseline not in ids:
            raise H.HistoryError(f"--baseline {baseline}: no such run in {hist.where} (runs "
                                 f"{_id_ranges(ids) or 'none yet'})")


def _id_ranges(ids) -> str:
    return f"{min(ids)}-{max(ids)}" if ids else ""


# -----------------------------------------------------------------------------------------------------
@dataclass
class Comparison:
    """One run (not yet recorded) against its series in the history."""

    environment: str
    series: list[dict]  # the stored runs of its series, oldest first
    current: dict  # {(scenario, method, dt, metric): value} of the run
    current_row: dict  # its runs-table row
    previous: dict | None = None  # the last stored run of the series
    baseline_runs: list[dict] = field(default_factory=list)
    baseline_label: str = ""
    since_previous: list[H.Change] = field(default_factory=list)
    since_baseline: list[H.Change] = field(default_factory=list)
    trend_metrics: list[dict] = field(default_factory=list)  # metrics of the series' newest TREND_RUNS runs
    thresholds: H.Thresholds = field(default_factory=H.Thresholds)

    @property
    def regressions(self) -> list[H.Change]:
        seen, out = set(), []
        for c in self.since_previous + self.since_baseline:
            key = (c.kind, c.scenario, c.method, c.dt)
            if c.regression and key not in seen:
                seen.add(key)
                out.append(c)
        return out

    def lines(self) -> list[str]:
        """What the terminal says: the regressions (against the previous run or the baseline), then the
        improvements since the baseline, each tagged with the environment when it is not the running one."""
        where = f" [{self.environment}]" if self.environment else ""
        if self.previous is None:
            return [f"history{where}: the first run of its series"]
        return [c.line() + where for c in self.regressions + [c for c in self.since_baseline if not c.regression]]

    def to_json(self) -> dict:
        def rows(changes):
            return [{"kind": c.kind, "scenario": c.scenario, "method": c.method, "dt": c.dt, "before": c.before,
                     "after": c.after, "regression": c.regression, "line": c.line()} for c in changes]

        return {"environment": self.environment, "previous_run": self.previous["id"] if self.previous else None,
                "baseline": self.baseline_label, "baseline_runs": [r["id"] for r in self.baseline_runs],
                "since_previous": rows(self.since_previous), "since_baseline": rows(self.since_baseline)}


def compare_run(location, results: dict, *, throughput=None, environment: str = "", host: str,
                baseline: int | None = None, last: int = 7, thresholds: H.Thresholds = H.Thresholds()) -> Comparison:
    """Compare a report's ``results.json`` document (and its ``xcheck bench`` rows) with its series in the
    history at ``location`` (which may not exist yet: then there is nothing to compare with)."""
    current = H.as_dict([*H.report_metrics(results), *H.bench_metrics(throughput)])
    row = H.run_row(results, started="", finished="", host=host, environment=environment)
    cmp = Comparison(environment=environment, series=[], current=current, current_row=row, thresholds=thresholds)
    if not H.is_url(location) and not Path(location).exists():
        return cmp
    with H.open_history(location, read_only=True) as hist:
        cmp.series = hist.runs(quick=bool(row["quick"]), environment=environment)
        if cmp.series:
            cmp.previous = cmp.series[-1]
            before = H.baseline_metrics(hist, [cmp.previous], host=host)
            cmp.since_previous = H.compare(before, current, thresholds)
        if baseline is not None:
            cmp.baseline_runs = [r for r in hist.runs() if r["id"] == baseline]
            cmp.baseline_label = f"run {baseline}"
        else:
            cmp.baseline_runs = cmp.series[-last:]
            ids = _id_ranges([r["id"] for r in cmp.baseline_runs])
            cmp.baseline_label = (f"the median of the last {len(cmp.baseline_runs)} runs, {ids}" if cmp.baseline_runs
                                  else "")
        if cmp.baseline_runs:
            cmp.since_baseline = H.compare(H.baseline_metrics(hist, cmp.baseline_runs, host=host), current,
                                           thresholds)
        cmp.trend_metrics = [hist.metrics(r["id"]) for r in cmp.series[-TREND_RUNS:]]
    return cmp


# -----------------------------------------------------------------------------------------------------
def keep_newest(out_root, keep: int, *, protect=()) -> list[Path]:
    """Delete all but the newest ``keep`` report folders in ``out_root``; returns what was deleted.

    A report folder is a direct subfolder named like a report stamp (``20261123T020000Z``, or ``-2`` ... for a
    second one in the same second) holding a ``results.json``; nothing else is touched. Never deleted: the
    folder ``latest`` points to, and those in ``protect`` (this run's). Two nightlies pruning at once each delete,
    and return, only what they took away themselves."""
    import re

    out_root = Path(out_root)
    stamp = re.compile(r"^\d{8}T\d{6}Z(-\d+)?$")
    keep_too = {Path(p).resolve() for p in protect}
    latest = out_root / "latest"
    if latest.is_symlink() or latest.is_dir():
        keep_too.add(latest.resolve())
    elif (out_root / "latest.txt").is_file():
        keep_too.add((out_root / (out_root / "latest.txt").read_text().strip()).resolve())
    reports = [p for p in out_root.iterdir() if stamp.match(p.name) and p.is_dir() and not p.is_symlink()
               and (p / "results.json").is_file()]
    reports.sort(key=lambda p: (p.name[:16], int(p.name[17:] or 1)), reverse=True)
    removed = []
    for p in reports[keep:]:
        if p.resolve() in keep_too:
            continue
        gone = p.with_name(f".{p.name}.removing-{os.getpid()}")
        try:  # taken away first, in one step: a nightly running beside this one deletes (and names) it or not
            p.rename(gone)
        except FileNotFoundError:
            continue
        shutil.rmtree(gone, ignore_errors=True)
        removed.append(p)
    return removed


# -----------------------------------------------------------------------------------------------------
# the nightly as a piece of work
# -----------------------------------------------------------------------------------------------------
@dataclass
class NightlyOutcome:
    """What :func:`run_nightly` did: the report (:class:`~xcheck.report.build.ReportOutcome`), the id of the
    run it recorded, the comparisons (the run's own, then each matrix release's), the older report folders
    ``keep`` removed, and the wall time [s]."""

    report: object
    run_id: int
    location: str
    comparisons: list
    removed: list
    wall_time: float

    @property
    def regressions(self) -> list:
        return [c for cmp in self.comparisons for c in cmp.regressions]

    @property
    def passed(self) -> bool:
        return self.report.passed and not self.regressions

    def verdict(self) -> str:
        n = len(self.regressions)
        return (f"{self.report.outcome}, no regression" if not self.regressions else
                f"{self.report.outcome}, {n} regression{'s' * (n != 1)}")


def run_nightly(scenarios, out, *, location, baseline: int | None = None, last: int = 7,
                thresholds: H.Thresholds = H.Thresholds(), versions=(), quick: bool = False,
                workers: int | None = None, bench: bool = False, keep: int | None = None, progress=None,
                written=None, started: float | None = None) -> NightlyOutcome:
    """The nightly of ``scenarios`` (resolved, distinct) into ``out``, compared with and then recorded in the
    history at ``location`` (checked here first, before any work): the other MuJoCo ``versions`` first, each in
    its environment, then the report with its History section, then one transaction for every run, then
    ``keep``. ``written(folder)`` as soon as the report folder is complete."""
    from ..report.build import build_report

    check_history(location, baseline)
    host, commit = host_name(), git_commit()
    t0 = time.perf_counter()
    matrix, installed = [], None
    if versions:
        from .matrix import installed_mujoco, run_matrix

        installed = installed_mujoco()
        matrix = run_matrix(list(versions), [str(sc.path) for sc in scenarios], Path(out), quick=quick,
                            workers=workers)
    rows, comparisons = [], []

    def sections(results):  # the finished results document, read only: the History compares it with the history
        from ..report.render import Section
        from ..report.trends import history_section, version_table_blocks

        main = compare_run(location, results, throughput=rows, host=host, baseline=baseline, last=last,
                           thresholds=thresholds)
        comparisons.append(main)
        for vr, _, _ in matrix:
            if vr.results is not None:
                comparisons.append(compare_run(location, vr.results, host=host, last=last,
                                               environment=f"mujoco=={vr.version}", thresholds=thresholds))
        summary, blocks, figures = history_section(main, others=comparisons[1:])
        if versions:
            columns = [(vr.version, vr.results, vr.note, vr.folder and os.path.relpath(vr.folder, out))
                       for vr, _, _ in matrix]
            if installed in versions:
                columns.append((installed, results, "the installed release", None))
            columns.sort(key=lambda c: tuple(map(int, c[0].split("."))))
            blocks += version_table_blocks(columns, thresholds)
        return [Section(blocks=blocks, figures=figures, summary=summary,
                        results={"history": [c.to_json() for c in comparisons]})]

    began = H.utc_now()
    if bench:  # measured before the report so that its History section can compare the rows
        from ..bench import run_bench

        rows += run_bench(quick=quick, repeat=3)
    report = build_report(scenarios, out, quick=quick, workers=workers, bench=rows, sections=sections,
                          progress=progress, written=written, started=started)
    finished = H.utc_now()
    # the report is complete: record it and the matrix's runs, in one transaction
    runs = [dict(results=vr.results, started=v_started, finished=v_finished, git_commit=commit, host=host,
                 report=str(vr.folder), environment=f"mujoco=={vr.version}")
            for vr, v_started, v_finished in matrix if vr.results is not None]
    runs.append(dict(results=report.document, started=began,
                     finished=finished, git_commit=commit, host=host, report=str(report.folder.resolve()),
                     throughput=rows))
    try:
        with H.open_history(location) as hist:
            run_id = hist.record_runs(runs)[-1]
    except H.HistoryError as exc:
        raise H.HistoryError(f"{exc}; the report {report.folder} is complete") from None
    removed = []
    if keep is not None:
        roots = [Path(out)] + [Path(out) / f"mujoco-{vr.version}" for vr, _, _ in matrix]
        removed = [p for root in roots if root.is_dir() for p in keep_newest(root, keep, protect=[report.folder])]
    return NightlyOutcome(report=report, run_id=run_id, location=str(location), comparisons=comparisons,
                          removed=removed, wall_time=time.perf_counter() - t0)
