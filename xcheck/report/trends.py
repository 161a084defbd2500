"""The report's History section (``xcheck nightly``): trend plots of the key figures over the stored runs,
version changes marked on their time axis, the tables of what changed, and the MuJoCo version table."""

from __future__ import annotations

import math

from ..history.store import MIN_TIMED, VERSION_COLUMNS, finest_error
from ..trajectory import step_label
from .document import Cell, Figure, Heading, Para, Table

__all__ = ["history_section", "version_table_blocks"]


def history_section(cmp, *, others=(), trend_figures: bool = True):
    """``(summary, blocks, figures)`` of a :class:`~xcheck.history.nightly.Comparison`: a sentence for the report's
    first screen, the section's blocks, and its figures as ``[(file, caption, png)]``. ``others``: the
    comparisons of the version matrix's runs with their own series (their changes are listed too)."""
    regressions = cmp.regressions + [c for other in others for c in other.regressions]
    improved = [c for c in cmp.since_baseline if not c.regression]
    if cmp.previous is None:
        summary = ("History: the first run of its series in this history; from the next run on, the report says "
                   "what changed.")
    elif regressions:
        summary = (f"History: {len(regressions)} regression{'s' * (len(regressions) > 1)} since the previous run or "
                   f"the baseline (first: {regressions[0].line().removeprefix('REGRESSION: ')}).")
    else:
        summary = (f"History: no regression since the previous run (run {cmp.previous['id']}) or the baseline"
                   + (f"; {len(improved)} figure{'s' * (len(improved) > 1)} improved." if improved else "."))
    blocks = [Heading(2, "History", anchor="history",
                      badge=("regression", "fail") if regressions else ("no regression", "pass")),
              Para(summary)]
    rows = cmp.series[-len(cmp.trend_metrics):] if cmp.trend_metrics else []
    figures = []
    if trend_figures and rows:
        points = cmp.trend_metrics + [cmp.current]
        labels = [_run_label(r) for r in rows] + ["this run"]
        marks = _version_changes(rows + [cmp.current_row])
        scenarios = list(dict.fromkeys(k[0] for k in cmp.current))
        for scenario in scenarios:
            figures.append(_trend_png(scenario, points, labels, marks))
        blocks.append(Para(f"Trends over the last {len(points)} runs of this series ({'quick' if cmp.current_row['quick'] else 'full'} "
                           "reports" + (f", environment {cmp.environment}" if cmp.environment else "") + ") on the "
                           "history's time axis; dotted lines mark a version change between two runs." +
                           (" Version changes: " + "; ".join(f"before {labels[i].splitlines()[0]}: {text}" for i, text in marks) + "."
                            if marks else " No version changed over these runs."), small=True))
    blocks += [Figure(file, caption) for file, caption, _ in figures]
    for title, changes, empty in (
            (f"Since the previous run (run {cmp.previous['id']}, {cmp.previous['started']})" if cmp.previous else "",
             cmp.since_previous, "Nothing moved beyond the thresholds."),
            (f"Since the baseline ({cmp.baseline_label})" if cmp.baseline_runs else "", cmp.since_baseline,
             "Nothing moved beyond the thresholds.")):
        if not title:
            continue
        blocks.append(Heading(3, title))
        blocks.append(change_table(changes) if changes else Para(empty, small=True))
    for other in others:
        changes = other.regressions + [c for c in other.since_baseline if not c.regression]
        blocks.append(Heading(3, f"{other.environment}: against its own series"))
        blocks.append(change_table(changes) if changes else Para(
            "The first run of its series." if other.previous is None else "Nothing moved beyond the thresholds.",
            small=True))
    th = cmp.thresholds
    speed = (f"steps per second down by more than {th.speed_drop:.0%} (only against runs on the same host; at each "
             f"method's finest step when that run lasted {MIN_TIMED:g} s or more, and the benchmark's rows)"
             if th.speed_drop < 1 else "speeds not compared (--speed-drop 1)")
    blocks.append(Para(f"Rules: a check that passed and fails; an attitude error that grew more than "
                       f"{th.error_factor:g}× above its study's floor; an observed order down by more than "
                       f"{th.order_drop:g}; {speed}. The same rules the other way round are improvements.",
                       small=True))
    return summary, blocks, figures


def change_table(changes) -> Table:
    def value(c, v):
        if c.kind == "check":
            return "passed" if v >= 0.5 else "failed"
        return f"{v:.2f}" if c.kind == "order" else f"{v:.3g}"

    what = {"check": "check", "error": "attitude error [rad]", "order": "observed order", "speed": "steps/s"}
    rows = [[Cell("REGRESSION", "fail") if c.regression else Cell("improved", "pass"), c.scenario,
             c.method or "(scenario)", "" if c.dt is None else step_label(c.dt), what[c.kind],
             Cell(value(c, c.before), num=True), Cell(value(c, c.after), num=True)]
            for c in sorted(changes, key=lambda c: (not c.regression, c.scenario, c.method, c.dt or 0))]
    return Table(["", "scenario", "method", "Δt [s]", "figure", "before", "after"], rows)


def _run_label(row) -> str:
    return f"run {row['id']}\n{(row['started'] or '')[5:16].replace('T', ' ')}"


def _version_changes(rows) -> list[tuple[int, str]]:
    """``[(index, "mujoco 3.6.0 → 4.0.0")]``: the versions that differ from the run before."""
    out = []
    for i in range(1, len(rows)):
        moved = [f"{k} {rows[i - 1][k]} → {rows[i][k]}" for k in VERSION_COLUMNS
                 if rows[i - 1].get(k) != rows[i].get(k)]
        if moved:
            out.append((i, ", ".join(moved)))
    return out


def _finest_speed(metrics: dict, scenario: str, method: str):
    rows = [(k[2], v) for k, v in metrics.items() if k[0] == scenario and k[1] == method
            and k[3] == "steps_per_second" and k[2] is not None and v]
    return min(rows)[1] if rows else None


def _trend_png(scenario, points, labels, marks):
    from .plots import colors_of, line_style, png_of, subplots

    methods = list(dict.fromkeys(k[1] for p in points for k in p if k[0] == scenario and k[1]
                                 and k[3] == "observed_order"))
    colors = colors_of(methods)
    fig, axes = subplots(3, 1, size=(9.5, 8.0), legend_outside=True, sharex=True)
    x = list(range(len(points)))
    panels = [("finest error [rad]", lambda p, m: p.get((scenario, m, None, "finest_error")), True),
              ("observed order", lambda p, m: p.get((scenario, m, None, "observed_order")), False),
              ("steps/s (finest step)", lambda p, m: _finest_speed(p, scenario, m), True)]
    for ax, (label, get, log) in zip(axes, panels):
        for m in methods:
            y = [get(p, m) for p in points]
            y = [math.nan if v is None or (log and v <= 0) else v for v in y]
            if all(math.isnan(v) for v in y):
                continue
            ax.plot(x, y, line_style(m), color=colors[m], label=m, marker="o", markersize=3)
        if log:
            ax.set_yscale("log")
        ax.set_ylabel(label)
        for i, text in marks:
            ax.axvline(i - 0.5, color="0.3", linestyle=":", linewidth=1)
    for i, text in marks:
        axes[0].annotate(text, (i - 0.5, 1.0), xycoords=("data", "axes fraction"), rotation=90, fontsize=6,
                         va="top", ha="right", color="0.3")
    step = max(1, math.ceil(len(x) / 12))
    ticks = sorted(set(x[::-step][::-1]) | {x[-1]})
    axes[-1].set_xticks(ticks, [labels[i] for i in ticks], fontsize=7)
    axes[-1].set_xlim(-0.5, len(x) - 0.5)
    axes[0].set_title(f"{scenario}: trends over the stored runs")
    handles, names = axes[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="center right", fontsize=7)
    return png_of(fig, f"{scenario}-history.png",
                f"{scenario}: finest attitude error, observed order and steps per second at the finest step, per "
                "method, over the stored runs of this series and this run (right); dotted: a version changed.")


# -----------------------------------------------------------------------------------------------------
def version_table_blocks(columns: list[tuple], thresholds=None) -> list:
    """The MuJoCo version table: ``columns`` are ``(version, results.json document or None, note, report folder
    or None)`` in release order. Per scenario and MuJoCo integrator: the observed order and the finest error by release; a
    cell that moved beyond the regression thresholds from its left neighbour is marked (red worse, green
    better)."""
    from ..history.store import Thresholds

    th = thresholds or Thresholds()
    blocks = [Heading(2, "MuJoCo versions", anchor="mujoco-versions"),
              Para("The same scenarios run against each MuJoCo release, each in its own virtual environment. Each "
                   "cell: observed order p and the attitude error [rad] at the finest step; marked where it moved "
                   "beyond the regression thresholds (order by 0.3, error by 10×) from the release to its left.",
                   small=True)]
    for version, doc, note, folder in columns:
        if doc is None:
            blocks.append(Para([(f"MuJoCo {version}: ", "b"), (note, None)]))
        elif folder:
            blocks.append(Para([(f"MuJoCo {version}: ", "b"), (f"{note}; its report: ", None), (folder, "code")],
                               small=True))
    docs = [(v, {s["scenario"]: s for s in doc["scenarios"]}) for v, doc, _, _ in columns if doc is not None]
    if not docs:
        return blocks
    scenarios = list(dict.fromkeys(s for _, by in docs for s in by))
    for scenario in scenarios:
        methods = list(dict.fromkeys(m for _, by in docs if scenario in by
                                     for m, d in by[scenario]["methods"].items() if d.get("engine") == "mujoco"))
        rows = []
        for m in methods:
            cells, left = [], None
            for _, by in docs:
                d = by.get(scenario, {}).get("methods", {}).get(m)
                if d is None:
                    cells.append(Cell())
                    left = None
                    continue
                p, e = d.get("observed_order"), finest_error(d)
                cls = ""
                if left is not None:
                    lp, le = left
                    worse = (lp is not None and p is not None and lp - p > th.order_drop) or (
                        le is not None and e is not None and e > th.error_factor * le)
                    better = (lp is not None and p is not None and p - lp > th.order_drop) or (
                        le is not None and e is not None and le > th.error_factor * e)
                    cls = "fail" if worse else ("pass" if better else "")
                cells.append(Cell(f"p={'—' if p is None else format(p, '.2f')} · "
                                  f"{'—' if e is None else format(e, '.1e')}", cls))
                left = (p, e)
            rows.append([m] + cells)
        blocks.append(Heading(3, scenario))
        blocks.append(Table(["method"] + [f"MuJoCo {v}" for v, _ in docs], rows))
    return blocks
