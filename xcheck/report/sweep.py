"""A sweep's folder (``xcheck sweep``): the tidy table, the database, the figures and index.html.

``<out>/<spec stem>/<stamp>/``: ``results.csv`` (one row per cell x method x step), ``sweep.sqlite`` (the
nightly history's schema, cells' parameters in ``sweep_cells``), ``cells.jsonl`` (every cell's record: what
``--resume`` reads), ``sweep.json`` (the spec, versions, timings), ``plots/*.png`` and an
``index.html``. Written into a hidden folder and renamed into place when complete; ``latest`` points at it.
"""

from __future__ import annotations

import math
import shutil
import warnings
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from ..base.files import (
    StampedFolder,
    write_bytes_atomic,
    write_json_atomic,
    write_text_atomic,
)
from ..history.store import finest_error
from ..runners import RUNNERS
from ..sweep.spec import AXES, SUMMARIES, SweepSpec, flat_params
from ..trajectory import step_label
from ..versions import machine, versions
from .document import Cell, Figure, Heading, Para, Table, Verdict, to_html, to_markdown
from .render import fmt

__all__ = ["write_sweep", "sweep_figures", "tidy_rows", "csv_text", "SWEEP_SCHEMA", "ACCURACY"]

SWEEP_SCHEMA = "xcheck.sweep/1"
#: The accuracy map's contour [rad]: the largest attitude error over a run that a user asks for.
ACCURACY = 1e-6
#: Attitude errors below this are drawn at it (a log axis has no zero).
_FLOOR = 1e-17
#: One marker per method (drawn hollow: points of methods that agree stay visible on top of each other).
_MARKERS = "os^Dv<>pPXh*"


def write_sweep(spec: SweepSpec, records: list, root: Path, *, methods, timings: dict, ran: int, reused: int,
                wall_time: float, log: Path) -> Path:
    """Write the folder of a finished sweep under ``root`` (see the module docstring); returns it."""
    from ..history.store import History, utc_now

    folder = StampedFolder(root)
    with folder as tmp:
        by_id = {r["id"]: r for r in records}
        rows = tidy_rows(spec, by_id)
        write_text_atomic(tmp / "results.csv", csv_text(rows))
        shutil.copyfile(log, tmp / "cells.jsonl")
        summary = _summary(spec, records, methods, timings, ran, reused, wall_time)
        write_json_atomic(tmp / "sweep.json", summary)
        figures = sweep_figures(spec, rows, methods)
        for file, _, png in figures:
            write_bytes_atomic(tmp / "plots" / file, png)
        document = sweep_document(spec, records, summary, [(f, c) for f, c, _ in figures], methods)
        write_text_atomic(tmp / "report.md", to_markdown(document))
        write_text_atomic(tmp / "index.html", to_html(document, tmp / "plots", title=f"xcheck sweep {spec.path.stem}"))
        base = spec.base.name
        results = {"versions": summary["versions"], "machine": summary["machine"], "quick": True,
                   "passed": all(r["passed"] for r in records),
                   "scenarios": [{"scenario": f"{base}/{r['id']}", "passed": r["passed"],
                                  "order_floor": r["order_floor"], "checks": r["checks"], "methods": r["methods"]}
                                 for r in records]}
        cells = [(f"{base}/{r['id']}", k, v) for r in records for k, v in flat_params(r["params"]).items()]
        now = utc_now()
        with History(tmp / "sweep.sqlite") as db:
            db.record_runs([dict(results=results, started=summary["created"], finished=now, report=None,
                                 environment=f"sweep:{spec.path.stem}", cells=cells)])
    return folder.final


def _summary(spec, records, methods, timings, ran, reused, wall_time) -> dict:
    return {"schema": SWEEP_SCHEMA, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "spec": str(spec.path), "description": spec.description, "base": spec.base.name,
            "base_file": str(spec.base.path), "combine": spec.combine, "seed": spec.seed, "samples": spec.samples,
            "axes": [a.name for a in spec.axes], "methods": list(methods), "steps": list(spec.steps),
            "cells": len(records), "cells_passed": sum(r["passed"] for r in records), "ran": ran,
            "reused": reused, "wall_time": wall_time, "timings": timings, "versions": versions(),
            "machine": machine()}


# ------------------------------------------------------------------------------------------------------
# the tidy table
# ------------------------------------------------------------------------------------------------------
RUN_COLUMNS = ("dt", "rtol", "status", "attitude_error", "max_attitude_error", "omega_error", "max_omega_error",
               "energy_change", "momentum_change", "momentum_turn", "norm_drift", "wall_time", "repeats",
               "evaluations", "steps_per_second")


def tidy_rows(spec: SweepSpec, records: dict[str, dict]) -> list[dict]:
    """One row per cell x method x step, cells in the spec's order: the cell's flat parameters, the method's
    expected and observed order and verdict, and the run's metrics."""
    rows = []
    for cell in spec.cells:
        rec = records[cell["id"]]
        params = flat_params(cell["params"])
        for name, m in rec["methods"].items():
            for r in m["runs"]:
                rows.append({"cell": cell["id"], **params, "method": name, "engine": m["engine"],
                             "expected_order": m["expected_order"], "observed_order": m["observed_order"],
                             "verdict": m["verdict"], **{k: r.get(k) for k in RUN_COLUMNS},
                             "message": r.get("message", "")})
    return rows


def csv_text(rows: list[dict]) -> str:
    """The rows as CSV (floats in their shortest form that reads back exactly; None an empty field)."""
    import csv
    import io

    columns = list(dict.fromkeys(k for r in rows for k in r))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow(["" if r.get(c) is None else (repr(r[c]) if isinstance(r[c], float) else r[c])
                    for c in columns])
    return buf.getvalue()



# ------------------------------------------------------------------------------------------------------
# figures
# ------------------------------------------------------------------------------------------------------
def _axis_column(axis) -> tuple[str, str, bool]:
    """(column of the tidy table, axis label, categorical?) of a swept axis."""
    if axis.name in SUMMARIES:
        return SUMMARIES[axis.name][0], SUMMARIES[axis.name][1], False
    if axis.name == "torques":
        return axis.name, "torque terms kept", True
    if axis.name in ("model", "field"):
        return axis.name, AXES[axis.name].help, True
    label = AXES[axis.name].help if axis.name in AXES else f"{axis.name.removeprefix('field.')} (field model)"
    return axis.name, label, False


def _at_step(rows, dt) -> dict:
    """{(cell, method): the row of the method's good run at the step ``dt`` in the cell}."""
    return {(r["cell"], r["method"]): r for r in rows
            if r["dt"] == dt and r.get("rtol") is None and r["status"] == "ok" and r["attitude_error"] is not None}


def sweep_figures(spec: SweepSpec, rows: list, methods) -> list[tuple[str, str, bytes]]:
    """``[(file, caption, png)]``: error against each axis, the accuracy maps of MuJoCo's integrators, the
    work-precision cloud."""
    import matplotlib

    from .plots import png_of

    stem = spec.path.stem
    cmap = matplotlib.colormaps.get_cmap("tab10" if len(methods) <= 10 else "tab20")
    colors = {m: cmap(i % cmap.N) for i, m in enumerate(methods)}
    figs = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if spec.axes:
            figs.append(png_of(_error_by_axis(spec, rows, methods, colors), f"{stem}-error-by-axis.png",
                             f"Attitude error at the final time at the sweep's largest step, Δt = "
                             f"{step_label(max(spec.steps))} s (where the methods' own errors stand above round-off), "
                             "against each swept axis: one point per cell and method; a model or field model axis "
                             "shows its values side by side, spread sideways so that points do not hide each other. "
                             "A method missing from a cell failed there (see the table)."))
        mj = [m for m in methods if RUNNERS[m].engine == "mujoco"]
        # the map's columns: the first axis that is a physical parameter (not a random draw), else any numeric one
        chosen = next((a for a in spec.axes if not a.random), None) or next(
            (a for a in spec.axes if not _axis_column(a)[2]), None)
        if mj and chosen is not None and len(spec.steps) > 1:
            figs.append(png_of(_accuracy_maps(spec, rows, mj, chosen), f"{stem}-accuracy-map.png",
                             f"Accuracy map of MuJoCo's integrators: the largest attitude error over the run "
                             f"(colour, log scale) for each step and {_axis_column(chosen)[1]}; where other axes "
                             f"vary too, the worst cell. The white line is the {ACCURACY:g} rad contour: below it "
                             "(smaller steps) the body is simulated within that accuracy. Grey: a run failed "
                             "there; blank: no cell."))
        figs.append(png_of(_work_precision(rows, methods, colors), f"{stem}-work-precision.png",
                         "Work against precision over every cell, method and step: the wall time of a run against "
                         "its attitude error at the final time (lower left is better). Batched methods' times are "
                         "the batch call's share per cell."))
    return figs


def _log_if_wide(ax, values, axis="x"):
    v = np.asarray([x for x in values if x is not None and x > 0 and math.isfinite(x)], dtype=float)
    if len(v) and v.min() > 0 and v.max() / v.min() > 20:
        (ax.set_xscale if axis == "x" else ax.set_yscale)("log")


def _error_by_axis(spec, rows, methods, colors):
    from .plots import subplots

    finest = _at_step(rows, max(spec.steps))
    n = len(spec.axes)
    ncols = 1 if n == 1 else 2
    nrows = math.ceil(n / ncols)
    height = 3.6 * nrows + 0.9
    fig, axes = subplots(nrows, ncols, size=(11 if ncols == 2 else 8, height), squeeze=False)
    fig.subplots_adjust(wspace=0.25, hspace=0.45, top=1 - 0.85 / height)
    rng = np.random.default_rng(0)  # the sideways spread of categorical points: fixed, for identical figures
    for ax, axis in zip(axes.flat, spec.axes):
        column, label, categorical = _axis_column(axis)
        cats = list(dict.fromkeys(r[column] for r in finest.values())) if categorical else []
        for k, m in enumerate(methods):
            pts = [(r[column], r["attitude_error"]) for (cell, meth), r in finest.items() if meth == m]
            if not pts:
                continue
            x, y = zip(*pts)
            if categorical:
                offset = (k - (len(methods) - 1) / 2) * 0.6 / max(len(methods), 1)
                x = np.array([cats.index(v) for v in x]) + offset + rng.uniform(-0.02, 0.02, len(x))
            ax.scatter(x, np.maximum(y, _FLOOR), s=18, facecolors="none", edgecolors=colors[m], alpha=0.8, label=m,
                       marker=_MARKERS[k % len(_MARKERS)], linewidths=1.0)
        ax.set_yscale("log")
        if categorical:
            ax.set_xticks(range(len(cats)))
            ax.set_xticklabels([str(c) for c in cats], fontsize=8)
        else:
            _log_if_wide(ax, [r[column] for r in finest.values()])
        ax.set_xlabel(label)
        ax.set_ylabel("attitude error [rad]")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if labels:
        fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 1 - 0.3 / height),
                   ncol=min(len(labels), 6), fontsize=8, frameon=False, markerscale=1.5)
    else:  # every run failed: the tables say why; the figure says that there is nothing to draw
        axes.flat[0].text(0.5, 0.5, "no run of any method completed", transform=axes.flat[0].transAxes,
                          ha="center", va="center", fontsize=10)
    fig.suptitle(f"{spec.path.stem}: error against the swept axes at Δt = {step_label(max(spec.steps))} s", fontsize=10)
    return fig


def _accuracy_maps(spec, rows, mj_methods, axis):
    """One panel per MuJoCo integrator: step (y) against the axis (x), coloured by the worst largest attitude
    error over the cells at that point, with the :data:`ACCURACY` contour."""
    from matplotlib.colors import LogNorm

    from .plots import subplots

    column, label, categorical = _axis_column(axis)
    xs = list(dict.fromkeys(r[column] for r in rows if r[column] is not None))
    xs = xs if categorical else sorted(xs)
    binned = len(xs) > 16 and not categorical
    if binned:  # a sampled axis: 12 bins (logarithmic where it spans decades), drawn at their true positions
        lo, hi = xs[0], xs[-1]
        log_x = lo > 0 and hi / lo > 20
        edges = np.geomspace(lo, hi, 13) if log_x else np.linspace(lo, hi, 13)

        def xbin(v):
            return int(min(np.searchsorted(edges, v, side="right") - 1, 11))
        xe = edges
    else:  # a grid: one column per value, evenly spaced, labelled with the values
        def xbin(v):
            return xs.index(v)
        xe = np.arange(len(xs) + 1) - 0.5
    steps = sorted(spec.steps)
    ye = np.arange(len(steps) + 1) - 0.5  # one row per step, finest at the bottom
    n = len(mj_methods)
    ncols = 1 if n == 1 else 2
    nrows = math.ceil(n / ncols)
    height = 3.8 * nrows + 0.7
    fig, axes = subplots(nrows, ncols, size=(11 if ncols == 2 else 7.5, height), squeeze=False)
    fig.subplots_adjust(left=0.08, right=0.87, wspace=0.25, hspace=0.5, bottom=0.6 / height, top=1 - 0.7 / height)
    errs = [r["max_attitude_error"] for r in rows if r["method"] in mj_methods and r["max_attitude_error"]]
    vmin = max(min(errs, default=1e-12), 1e-16)
    vmax = max(max(errs, default=1.0), vmin * 10)
    norm = LogNorm(vmin=vmin, vmax=vmax)
    import matplotlib
    from matplotlib.colors import ListedColormap

    cmap = matplotlib.colormaps.get_cmap("viridis")
    mesh = None
    for ax, m in zip(axes.flat, mj_methods):
        Z = np.full((len(steps), len(xe) - 1), -np.inf)
        failed = np.zeros_like(Z, dtype=bool)
        for r in rows:
            if r["method"] != m or r[column] is None:
                continue
            i, j = steps.index(r["dt"]), xbin(r[column])
            if r["status"] != "ok" or r["max_attitude_error"] is None:
                failed[i, j] = True
            else:
                Z[i, j] = max(Z[i, j], r["max_attitude_error"])
        Z = np.where(failed | ~np.isfinite(Z), np.nan, np.maximum(Z, vmin))
        mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(Z), norm=norm, cmap=cmap, shading="flat")
        if failed.any():
            ax.pcolormesh(xe, ye, np.ma.masked_where(~failed, np.ones_like(Z)), cmap=ListedColormap(["0.6"]),
                          shading="flat")
        lo, hi = np.nanmin(Z, initial=np.inf), np.nanmax(Z, initial=-np.inf)
        if lo < ACCURACY < hi and Z.shape[1] > 1:
            xc = 0.5 * (xe[:-1] + xe[1:]) if not binned else np.sqrt(xe[:-1] * xe[1:]) if log_x else 0.5 * (xe[:-1] + xe[1:])
            cs = ax.contour(xc, np.arange(len(steps)), np.log10(np.where(np.isnan(Z), vmax, Z)),
                            levels=[math.log10(ACCURACY)], colors="white", linewidths=2, linestyles="solid")
            ax.clabel(cs, fmt={math.log10(ACCURACY): f"{ACCURACY:g} rad"}, fontsize=8)
        elif np.isfinite(lo):
            word = "every run within" if hi <= ACCURACY else "every run above" if lo >= ACCURACY else ""
            if word:
                ax.text(0.02, 0.97, f"{word} {ACCURACY:g} rad", transform=ax.transAxes, va="top", fontsize=8,
                        color="white", bbox=dict(facecolor="0.2", alpha=0.6, edgecolor="none"))
        ax.set_yticks(range(len(steps)))
        ax.set_yticklabels([step_label(s) for s in steps], fontsize=8)
        if binned:
            if log_x:
                ax.set_xscale("log")
        else:
            ax.set_xticks(range(len(xs)))
            ax.set_xticklabels([format(v, ".3g") if isinstance(v, float) else str(v) for v in xs], fontsize=8)
        ax.set_xlabel(label)
        ax.set_ylabel("step Δt [s]")
        ax.set_title(m, fontsize=9)
        ax.grid(False)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    cax = fig.add_axes([0.9, 0.6 / height, 0.018, 1 - 1.3 / height])
    fig.colorbar(mesh, cax=cax, label="largest attitude error over the run [rad]")
    fig.suptitle(f"{spec.path.stem}: which step does the body need? (MuJoCo's integrators)", fontsize=10)
    return fig


def _work_precision(rows, methods, colors):
    from .plots import subplots

    fig, ax = subplots(size=(8.5, 5), legend_outside=True)
    for m in methods:
        pts = [(r["wall_time"], r["attitude_error"]) for r in rows
               if r["method"] == m and r["status"] == "ok" and r["attitude_error"] is not None and r["wall_time"]]
        if pts:
            x, y = zip(*pts)
            ax.scatter(x, np.maximum(y, _FLOOR), s=14, alpha=0.6, facecolors="none", edgecolors=colors[m], label=m,
                       marker=_MARKERS[methods.index(m) % len(_MARKERS)], linewidths=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time of a run [s]")
    ax.set_ylabel("attitude error at the final time [rad]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8, frameon=False, markerscale=2)
    ax.set_title("work against precision, every cell, method and step", fontsize=10)
    return fig


# ------------------------------------------------------------------------------------------------------
# the document
# ------------------------------------------------------------------------------------------------------
def sweep_document(spec: SweepSpec, records, summary, figures, methods) -> list:
    n = len(records)
    passed = summary["cells_passed"]
    blocks = [Heading(1, f"xcheck sweep: {spec.path.stem}"),
              Verdict(f"{passed} of {n} cells passed every check", "pass" if passed == n else "fail")]
    if spec.description:
        blocks.append(Para(spec.description))
    axes = ", ".join(a.name for a in spec.axes) or "none"
    how = ("the Cartesian product of the axes" if spec.combine == "product"
           else f"{spec.samples} samples (seed {spec.seed})")
    blocks.append(Para([("Base scenario ", None), (spec.base.name, "code"), (f" ({spec.base.reference} reference, "
                        f"{spec.base.duration:g} s); axes: {axes}; cells: {n}, {how}; steps: "
                        f"{', '.join(step_label(s) for s in spec.steps)} s; spec ", None), (str(spec.path), "code"),
                        (".", None)]))
    blocks += [Heading(2, "Methods over the cells", anchor="methods"), _method_table(records, methods)]
    blocks.append(Para("Finest error: the attitude error at the final time at each method's finest step, median "
                       "and worst over the cells. Largest Δt within 1e-6 rad: the largest step whose largest "
                       "error over the run stays within 1e-6 rad, in the worst cell (the step that serves every "
                       "cell).", small=True))
    failing = [r for r in records if not r["passed"]]
    if failing:
        blocks += [Heading(2, f"Cells that failed a check ({len(failing)})", anchor="failing"),
                   _failing_table(failing[:20])]
        if len(failing) > 20:
            blocks.append(Para(f"... and {len(failing) - 20} more: see results.csv.", small=True))
    blocks.append(Heading(2, "Figures", anchor="figures"))
    blocks += [Figure(f, c) for f, c in figures]
    t = summary["timings"]
    blocks += [Heading(2, "Run", anchor="run"),
               Para(f"{summary['ran']} cells ran now" + (f", {summary['reused']} came from an earlier run (--resume)"
                                                         if summary["reused"] else "") +
                    f"; wall time {summary['wall_time']:.1f} s" +
                    (f"; {t['cells_per_second']:.2f} cells/s; per cell (median): model and torque "
                     f"{1e3 * t['context']:.1f} ms, reference {1e3 * t['reference']:.1f} ms, compute "
                     f"{1e3 * t['compute']:.1f} ms" if t.get("cells_per_second") else "") + "."),
               Para("Files: results.csv (one row per cell × method × step), sweep.sqlite (the nightly history's "
                    "tables, the cells' parameters in sweep_cells), cells.jsonl (every cell's record), sweep.json.",
                    small=True),
               Para("Versions: " + ", ".join(f"{k} {v}" for k, v in summary["versions"].items()), small=True)]
    return blocks


def _method_table(records, methods) -> Table:
    header = ["method", "engine", "expected order", "cells passed", "finest error median", "finest error worst",
              "observed order (min – max)", "largest Δt within 1e-6 rad"]
    rows = []
    for m in methods:
        finest, orders, within, good = [], [], [], 0
        for r in records:
            doc = r["methods"].get(m)
            if doc is None:
                continue
            good += doc["verdict"] in ("pass", "expected", "info")
            error = finest_error(doc)
            if error is not None:
                finest.append(error)
            if doc["observed_order"] is not None:
                orders.append(doc["observed_order"])
            within.append(doc["largest_step_within"].get("1e-06"))
        step = None if any(w is None for w in within) or not within else min(within)
        order = f"{min(orders):.2f} – {max(orders):.2f}" if orders else "—"
        exp = RUNNERS[m].expected_order
        rows.append([Cell(m), Cell(RUNNERS[m].engine), Cell("adaptive" if exp is None else str(exp), num=True),
                     Cell(f"{good} / {len(records)}", "pass" if good == len(records) else "fail", num=True),
                     Cell(fmt(float(np.median(finest)) if finest else None), num=True),
                     Cell(fmt(max(finest) if finest else None), num=True), Cell(order, num=True),
                     Cell(step_label(step) if step else "none", num=True)])
    return Table(header, rows)


def _failing_table(records) -> Table:
    rows = []
    for r in records:
        params = ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}"
                           for k, v in flat_params(r["params"]).items())
        notes = "; ".join(f"{c['name']}: {c['note']}" for c in r["checks"] if not c["passed"])
        rows.append([Cell(r["id"]), Cell(params), Cell(notes, "fail")])
    return Table(["cell", "parameters", "failed checks"], rows)
