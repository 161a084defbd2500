"""The report's attitude-determination section (:mod:`xcheck.determination.study` on a scenario's MuJoCo run, and seed
002 reproduced): blocks for :mod:`xcheck.report.document` and the figures as PNG bytes."""

from __future__ import annotations

import numpy as np

from .document import Cell, Figure, Heading, Para, Table
from .render import fmt

__all__ = ["determination_job", "determination_blocks", "seed002_blocks", "draw_determination"]

_COLORS = {"triad": "#d62728", "q-method": "#1f77b4", "quest": "#2ca02c", "svd": "#9467bd"}
_STYLES = {"triad": "-", "q-method": "-", "quest": "--", "svd": ":"}


def determination_job(scenario) -> tuple[dict, list]:
    """Run a scenario's determination study and draw its figures (in a worker): ``(data, figures)``."""
    from ..determination.study import run_determination

    data, series = run_determination(scenario)
    return data, draw_determination(data, series)


def draw_determination(data: dict, series: dict) -> list[tuple[str, str, bytes]]:
    """Two figures: the error of every method against time (one panel per noisy level, the predicted RMS
    dashed), and the RMS error against the angle between the two directions (the approach study)."""
    from .plots import png_of, subplots

    name = data["scenario"]
    out = []
    noisy = [lv for lv in data["levels"] if lv["predicted_rms"] is not None]
    if noisy:
        fig, axes = subplots(len(noisy), 1, size=(9.0, 2.6 * len(noisy) + 0.8), sharex=True, legend_outside=True)
        axes = np.atleast_1d(axes)
        t = series["t"]
        for ax, lv in zip(axes, noisy):
            errs = series["levels"][lv["name"]]["errors"]
            for m, err in errs.items():
                ax.semilogy(t, err, _STYLES.get(m, "-"), color=_COLORS.get(m), lw=1.0, label=m)
            ax.axhline(lv["predicted_rms"], color="k", ls="--", lw=1.2, label="predicted RMS (optimal)")
            ax.set_ylabel("error [rad]")
            ax.set_title(f"{lv['name']}: magnetometer {lv['magnetometer_nT']:g} nT, sun sensor {lv['sun_deg']:g}°",
                         fontsize=10)
            ax.grid(True, which="major", alpha=0.3)
        axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9)
        axes[-1].set_xlabel("t [s]")
        out.append(png_of(fig, f"{name}-determination-error.png",
                        "Attitude determination error against time, every method (q-method, QUEST and SVD coincide)"))
    ap = data.get("approach")
    if ap:
        fig, ax = subplots(size=(9.0, 4.8), legend_outside=True)
        a = np.asarray(ap["angles_deg"])
        for m, v in ap["methods"].items():
            ax.loglog(a, v["rms"], _STYLES.get(m, "-"), marker="o", ms=4, color=_COLORS.get(m), label=m)
        ax.loglog(a, ap["predicted_rms"], "k--", lw=1.2, label="predicted RMS (optimal)")
        ax.axvspan(min(a.min(), 1.0) / 1.5, 1.0, color="0.85", label="near-degenerate (< 1°)")
        ax.set_xlabel("angle between the field and the sun direction [deg]")
        ax.set_ylabel("RMS attitude error [rad]")
        ax.set_title(f"Accuracy lost as the two directions close up ({ap['level']})", fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9)
        out.append(png_of(fig, f"{name}-determination-approach.png",
                        "RMS attitude error against the angle between the two observed directions: it grows as "
                        "1/sin(angle), as predicted"))
    return out


def determination_blocks(data: dict, figures) -> list:
    """The section of one scenario's determination study; ``figures`` ``[(file, caption)]``."""
    name = data["scenario"]
    tr = data["truth"]
    ok = data["passed"]
    blocks = [Heading(2, f"Attitude determination on {name}", anchor=f"{name}-determination",
                      badge=("PASSED", "pass") if ok else ("FAILED", "fail")),
              Para(f"The truth: {tr['method']}'s attitude every {tr['dt']:g} s ({tr['samples']} samples over "
                   f"{tr['duration']:g} s). The magnetometer: {data['magnetometer']}. The sun sensor sees the "
                   f"inertial direction {[round(x, 4) for x in data['sun_direction']]}, "
                   f"{data['angle_deg']['min']:.1f}–{data['angle_deg']['max']:.1f}° from the field. Noise from seed "
                   f"{data['seed']}; weights 1/σ² of each direction; TRIAD takes the more accurate sensor first. "
                   "Predicted: Shuster's covariance, sqrt(mean tr P), the optimal methods' RMS error to first "
                   "order.")]
    rows = []
    for lv in data["levels"]:
        for m, s in lv["methods"].items():
            ratio = s["ratio_to_predicted"]
            rows.append([lv["name"] if m == next(iter(lv["methods"])) else "", m,
                         Cell(fmt(s["mean"]), num=True), Cell(fmt(s["rms"]), num=True),
                         Cell(fmt(lv["predicted_rms"]), num=True),
                         Cell("—" if ratio is None else f"{ratio:.3f}", num=True),
                         Cell(fmt(s["p95"]), num=True), Cell(fmt(s["max"]), num=True),
                         Cell(str(s["near_degenerate"]), num=True),
                         Cell("—" if not s["solutions_per_second"] else f"{s['solutions_per_second']:.3g}", num=True)])
    blocks.append(Table(["noise", "method", "mean [rad]", "RMS [rad]", "predicted RMS", "RMS / predicted",
                         "95 % [rad]", "max [rad]", "near-degenerate", "solutions/s"], rows))
    blocks.append(Table(["check", "result"], [[Cell(c["name"], "pass" if c["passed"] else "fail"), c["text"]]
                                              for c in data["checks"]]))
    ap = data.get("approach")
    if ap:
        head = ["angle [deg]", "predicted RMS"] + [f"{m} RMS" for m in ap["methods"]] + ["near-degenerate"]
        rows = []
        for i, a in enumerate(ap["angles_deg"]):
            flags = max(v["near_degenerate"][i] for v in ap["methods"].values())
            rows.append([Cell(f"{a:g}", num=True), Cell(fmt(ap["predicted_rms"][i]), num=True)]
                        + [Cell(fmt(v["rms"][i]), num=True) for v in ap["methods"].values()]
                        + [Cell(f"{flags} of {tr['samples']}", num=True)])
        blocks.append(Para(f"The approach study ({ap['level']}): the sun direction placed at each angle from the "
                           "field's at every sample. The error grows as 1/sin(angle); below 1° every solution is "
                           "flagged near-degenerate."))
        blocks.append(Table(head, rows))
    blocks += [Figure(file, caption) for file, caption in figures]
    return blocks


def _worst(*matches):
    """The failing match if any, else the one with the largest difference."""
    return max(matches, key=lambda m: (not m[1], m[0]))


def seed002_blocks(rep: dict) -> list:
    """Seed 002's tables reproduced, compactly (``xcheck determine --seed002`` prints them in full)."""
    def mark(match):
        return Cell(f"{'within' if match[1] else 'beyond'} the print's rounding ({match[0]:.1e})",
                    "pass" if match[1] else "fail")

    rows = []
    for row in rep["triad"]:
        i, k = row["pair"]
        rows.append([f"TRIAD ({i}, {k}): R, q", "4 decimals each", mark(_worst(row["R_match"], row["q_match"]))])
        rows.append([f"TRIAD ({i}, {k}): J", f"{row['J_printed']:g} → {row['J']:.5e}", mark(row["J_match"])])
    for name, row in rep["q_method"].items():
        rows.append([f"{name}, w = 1/4: q, R, J", f"J {rep['q_method_printed']['J']:g} → {row['J']:.4e}",
                     mark(_worst(row["q_match"], row["R_match"], row["J_match"]))])
    ws = rep["weight_search"]
    rows.append(["weight search w = (0.97, 0.01, 0.01, 0.01): J", f"{ws['J_printed']:g} → {ws['J']:.5e}",
                 mark(ws["J_match"])])
    ok = rep["passed"]
    return [Heading(2, "Seed 002 reproduced", anchor="seed002", badge=("PASSED", "pass") if ok else ("FAILED", "fail")),
            Para("Static attitude determination on the seed's four vector pairs (the MATLAB listing's v4b z = −0.2884; "
                 "the problem statement's −0.2882 moves R₁₄ by 2e−4, beyond the print). Every printed number is "
                 "matched to half a unit of its last digit. The seed's w = (1, 0, 0, 0) is refused: one direction "
                 "fixes the attitude only up to a rotation about it. xcheck determine --seed002 prints the tables."),
            Table(["quantity", "seed → xcheck", "match"], rows)]


def write_determination(data: dict, drawn, out_root, seed002: dict | None = None):
    """``xcheck determine SCENARIO --out DIR``: the section as its own report, ``DIR/<stamp>/`` written
    atomically (``index.html``, ``report.md``, ``results.json``, ``plots/``); returns the folder."""
    from datetime import datetime, timezone

    from ..base.files import (
        StampedFolder,
        write_bytes_atomic,
        write_json_atomic,
        write_text_atomic,
    )
    from ..versions import versions
    from .document import Verdict, to_html, to_markdown

    ok = data["passed"] and (seed002 is None or seed002["passed"])
    results = {"schema": "xcheck.determination/1", "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
               "versions": versions(), "passed": ok, "determination": [data]}
    blocks = [Heading(1, f"xcheck attitude determination: {data['scenario']}"),
              Verdict("PASSED: every check passed", "pass") if ok else Verdict("FAILED: some checks failed", "fail"),
              Para(f"Created {results['created']}. Versions: " + ", ".join(f"{k} {v}" for k, v in results["versions"].items()),
                   small=True)]
    blocks += determination_blocks(data, [(file, caption) for file, caption, _ in drawn])
    if seed002 is not None:
        blocks += seed002_blocks(seed002)
    folder = StampedFolder(out_root)
    with folder as tmp:
        for file, _, png in drawn:
            write_bytes_atomic(tmp / "plots" / file, png)
        write_json_atomic(tmp / "results.json", results)
        write_text_atomic(tmp / "report.md", to_markdown(blocks))
        write_text_atomic(tmp / "index.html", to_html(blocks, tmp / "plots", title="xcheck attitude determination"))
    return folder.final
