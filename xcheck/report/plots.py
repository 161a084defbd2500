"""Report figures (matplotlib, Agg backend): convergence like seed 004 Fig. 12, errors and invariants
against time, and the time histories of seed 001 (Figs. 13-23) and seed 004 (Figs. 9-11)."""

from __future__ import annotations

import warnings

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from .. import rotations as rot  # noqa: E402
from ..invariants import LABELS, largest_change  # noqa: E402
from ..runners import RUNNERS  # noqa: E402
from ..trajectory import step_label  # noqa: E402

__all__ = ["render_figures", "scenario_figures", "new_figure", "save_figure", "subplots", "png_of", "colors_of",
           "line_style", "run_figure", "side_legend", "horizon_figure"]

_STYLE = {"figure.dpi": 100, "savefig.dpi": 100, "font.size": 9, "axes.grid": True, "grid.alpha": 0.3,
          "axes.spines.top": False, "axes.spines.right": False, "legend.fontsize": 7,
          # what an engine's import may change for the whole process: Basilisk's scenario plot defaults
          # (Basilisk/utilities/simHelpers.py) turn on autolayout (a tight layout at every drawing: 3 s of CPU in a
          # quick report) and move every legend to the lower right
          "figure.autolayout": False, "figure.constrained_layout.use": False, "figure.facecolor": "white",
          "xtick.labelsize": "medium", "ytick.labelsize": "medium", "axes.labelsize": "medium", "legend.loc": "best"}
_MARKERS = "osD^v<>pPXh*"
# The report's style, set once for the process (a rc_context per figure deep-copies every parameter: a tenth of
# the drawing time). Figures are drawn by workers, or by the command that writes them: no one else's style to keep.
matplotlib.rcParams.update(_STYLE)


def colors_of(names):
    cmap = matplotlib.colormaps["tab20"]
    return {n: cmap(i % 20) for i, n in enumerate(names)}


def render_figures(data: dict, series: dict, *, quick: bool = False) -> list[tuple[str, str, bytes]]:
    """The figures of one scenario as PNG bytes, ``[(file name, caption, png)]`` (a worker draws them; the
    parent writes them into the report folder). ``quick``: without the time histories of the seeds' figures."""
    name = data["scenario"]
    figs = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        colors = colors_of(list(data["methods"]))
        measured = any(r["attitude_error"] is not None for m in data["methods"].values() for r in m["runs"])
        if not measured:  # every run failed, or no reference: the checks say why, an empty plot would not
            return figs
        figs.append(png_of(_convergence_and_cost(data, colors), f"{name}-convergence.png",
                         "Left: attitude error at the final time against the step (log-log), with slope guides "
                         "for orders 1 and 4; below the shaded line errors are at the study's floor (round-off or "
                         "the reference's own accuracy); like seed 004 Fig. 12. Right: the same errors against the "
                         "wall time of a run (the best of up to 5 runs of a short one), work against precision "
                         "(lower left is better), the adaptive methods (open markers) at each of their tolerances; "
                         "dotted lines at the tolerances of the step-size table."))
        figs += _files_figure(data, name)
        if data.get("comparisons"):
            figs.append(png_of(_comparisons(data, colors), f"{name}-direct.png",
                             "Direct cross-check, no reference: the largest attitude difference over the run "
                             "between each engine method and one of ours at the same step (same order where we "
                             "have one). It shrinks at the lower of the two orders until round-off."))
        if series:
            torque_free = data.get("torque") is None
            potential = "T + V" in next(iter(series.values())).get("energy_label", "")
            figs.append(png_of(_errors_in_time(series, colors, torque_free), f"{name}-error.png",
                             "Attitude error against time for the finest step of each method" +
                             ("; below it the relative change of the energy with its potential (T + V) and of the "
                              "angular momentum's component about the vertical, which the model's own torque "
                              "(gravity about the pivot) keeps" if torque_free and potential else
                              "; below it the relative change of the kinetic energy and of |L|, the world angular "
                              "momentum's magnitude, and the angle its direction turned (torque free: all three are "
                              "kept)" if torque_free else "") + (
                                 ": solid where the method gains, dashed where it damps (the sign of its largest "
                                 "change)." if torque_free else ".")))
            if quick:  # a fast look: the time histories of the seeds are in the full report
                return figs
            if data.get("torque") is None and "euler-rk4" in data["methods"]:
                figs += _euler_histories(data, series, name)
            if data.get("torque") is not None:
                figs += _torqued_histories(data, series, name)
            figs += _wheels_stiffness(data, name)
    return figs


def _files_figure(data, name):
    """Issue 39: each trajectory file's attitude and rate errors against time (log-log), with its tolerance."""
    files = data.get("files") or {}
    if not files:
        return []
    fig, (top, bottom) = subplots(2, 1, size=(7.5, 6.2), sharex=True, legend_outside=True)
    colors = colors_of(list(files))
    for label, f in files.items():
        t = np.array(f["series"]["t"], dtype=float)
        keep = t > 0
        for ax, key in ((top, "attitude_error"), (bottom, "rate_error")):
            if key in f["series"]:
                y = np.array([np.nan if v is None else v for v in f["series"][key]], dtype=float)
                ax.loglog(t[keep], np.maximum(y[keep], 1e-17), color=colors[label], lw=1.4,
                          label=f"{label} ({f['outcome'].lower()})" if ax is top else None)
    tol = {f["tolerance"] for f in files.values()}
    for value in tol:
        top.axhline(value, color="0.4", ls=":", lw=1)
    top.set_ylabel("attitude error [rad]")
    bottom.set_ylabel("rate error [rad/s]")
    bottom.set_xlabel("time [s]")
    top.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    for ax in (top, bottom):
        ax.grid(True, which="major", alpha=0.3)
    return [png_of(fig, f"{name}-files.png",
                   "The trajectory files scored against the reference: the attitude error (top) and the body-rate "
                   "error (bottom) against time, log-log; the dotted line is the files' tolerance. A straight line of "
                   "slope p is an error growing as t^p.")]


def _wheels_stiffness(data, name):
    """Issue 28: how a gyrostat's wheels stiffen its attitude, as the study computed it
    (:func:`xcheck.assembly.wheels_stiffness`). Nothing for a body without wheels."""
    stiffness = data.get("wheels_stiffness")
    if not stiffness:
        return []
    fig, ax = subplots(1, size=(7.5, 4.2))
    for label, angle in stiffness["angle_deg"].items():
        ax.plot(stiffness["t"], angle, lw=1.4, label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("wheels' axis from its start [deg]")
    ax.set_title(f"{name}: the wheels' momentum stiffens the attitude")
    ax.legend(frameon=False)
    return [png_of(fig, f"{name}-wheels-stiffness.png",
                   "The angle by which the direction of the wheels' momentum (a body axis) turns away from where it "
                   "started, in the world: with the wheels as the scenario has them, and with them stopped (the same "
                   "body as one rigid mass), under the same torque (lie-rkmk4 at 1/512 s). The wheels' momentum holds "
                   "the axis: gyroscopic stiffness.")]


def scenario_figures(data: dict, series: dict, out_dir, *, quick: bool = False) -> list[tuple[str, str]]:
    """:func:`render_figures` written into ``out_dir`` (each file atomically); returns ``[(file name, caption)]``."""
    from pathlib import Path

    from ..base.files import write_bytes_atomic

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    out = []
    for file, caption, png in render_figures(data, series, quick=quick):
        write_bytes_atomic(out_dir / file, png)
        out.append((file, caption))
    return out


def new_figure(*args, figsize=None, **kwargs):
    """``plt.subplots`` in the report's style, without pyplot (its import is 0.27 s a process; a figure of our own
    is in no global registry, so nothing needs closing)."""
    matplotlib.rcParams.update(_STYLE)  # again: a library run in this process since may have changed it
    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(*args, **kwargs)


def subplots(nrows=1, ncols=1, *, size=(7.5, 4.8), legend_outside=False, **kwargs):
    """A figure with fixed margins in inches (room on the right for a legend outside the axes): one drawing
    pass when saved, where ``bbox_inches="tight"`` costs a second one."""
    fig, axes = new_figure(nrows, ncols, figsize=size, **kwargs)
    w, h = size
    fig.subplots_adjust(left=0.85 / w, right=1 - (2.5 if legend_outside else 0.2) / w, top=1 - 0.35 / h,
                        bottom=0.5 / h, hspace=0.12 if kwargs.get("sharex") else 0.3, wspace=0.08)
    fig._xcheck_fixed = True
    return fig, axes


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _power(k: int) -> str:
    return f"{10.0 ** k:g}" if 0 <= k <= 2 else f"10{str(k).translate(_SUPERSCRIPT)}"


def _decade_label(value, _pos=None) -> str:
    """``10⁻¹²`` in plain Unicode for a log axis' decades ("" between them): matplotlib's default writes each
    tick label as mathtext, which cost half the drawing time of a report's figures."""
    if value <= 0:
        return ""
    k = np.log10(value)
    return _power(int(round(k))) if abs(k - round(k)) <= 1e-9 else ""


def _minor_label(value, _pos=None) -> str:
    """``2×10⁻³`` and ``5×10⁻³`` between the decades of a short log axis (plain text, as above)."""
    if value <= 0:
        return ""
    k = int(np.floor(np.log10(value) + 1e-9))
    m = value / 10.0 ** k
    return f"{m:.0f}×{_power(k)}" if min(abs(m - 2), abs(m - 5)) < 1e-6 else ""


def _plain_log_labels(fig) -> None:
    """Every log axis labelled in plain text (decades; 2 and 5 between them where it spans less than two
    decades, with minor ticks there only): each tick is an object to lay out, and the minor ticks of every decade
    of every log axis were half a report's drawing time."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter, NullLocator

    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            if axis.get_scale() != "log" or lo <= 0:
                continue
            decades = np.log10(hi) - np.log10(lo)
            axis.set_major_formatter(FuncFormatter(_decade_label))
            if decades < 2:
                axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
                axis.set_minor_formatter(FuncFormatter(_minor_label))
            else:
                axis.set_minor_locator(NullLocator())
                axis.set_minor_formatter(NullFormatter())


def _savefig(fig, target, fmt: str) -> None:
    _plain_log_labels(fig)
    fig.savefig(target, format=fmt, bbox_inches=None if getattr(fig, "_xcheck_fixed", False) else "tight")


def save_figure(fig, path) -> None:
    """Write ``fig`` to ``path`` atomically, in the format of its ending (``.png``, ``.svg``, ``.pdf``)."""
    import os
    from pathlib import Path

    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        _savefig(fig, tmp, path.suffix.lstrip(".").lower())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def run_figure(path, title, traj, err) -> None:
    """Quaternion, body rates and attitude error of one run, in the format of ``path``'s ending."""
    fig, axes = new_figure(3, 1, figsize=(7.5, 7), sharex=True)
    for k, c in enumerate("wxyz"):
        axes[0].plot(traj.t, traj.q[:, k], label=f"q{c}")
    for k, c in enumerate("xyz"):
        axes[1].plot(traj.t, traj.omega[:, k], label=f"ω{c}")
    if np.any(np.isfinite(err)):
        axes[2].semilogy(traj.t, np.maximum(err, 1e-17))
    axes[0].legend(ncol=4)
    axes[1].legend(ncol=3)
    axes[0].set_ylabel("quaternion")
    axes[1].set_ylabel("body rate [rad/s]")
    axes[2].set_ylabel("attitude error [rad]")
    axes[2].set_xlabel("t [s]")
    axes[0].set_title(title)
    save_figure(fig, path)


def png_of(fig, file, caption) -> tuple[str, str, bytes]:
    """The figure as PNG bytes with a palette of 128 colours (a third of the bytes of matplotlib's RGBA, no
    visible change on line plots), drawn once and encoded once."""
    import io

    from PIL import Image  # matplotlib's own dependency

    _plain_log_labels(fig)
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    image = Image.fromarray(rgba[..., :3]).quantize(128, method=Image.Quantize.FASTOCTREE)
    buffer = io.BytesIO()
    image.save(buffer, "PNG")
    return file, caption, buffer.getvalue()


def _convergence_and_cost(data, colors):
    """Two panels sharing the error axis and one legend: error against step, and against wall time."""
    fig, (ax, cost) = subplots(1, 2, size=(11.0, 4.6), legend_outside=True, sharey=True)
    _work_precision(cost, data, colors)
    all_dt, all_e = [], []
    for i, (name, entry) in enumerate(data["methods"].items()):
        if _adaptive(entry):  # its runs are a ladder of tolerances at one output step: work-precision only
            continue
        dt = np.array([r["dt"] for r in entry["runs"] if r["attitude_error"] is not None])
        e = np.array([r["attitude_error"] for r in entry["runs"] if r["attitude_error"] is not None])
        if len(dt) == 0:
            continue
        e = np.maximum(e, 1e-17)
        order = entry["observed_order"]
        label = f"{name} (p = {order:.2f})" if order is not None else name
        ax.loglog(dt, e, line_style(name), marker=_MARKERS[i % len(_MARKERS)], ms=4, lw=1.2, color=colors[name],
                  label=label)
        all_dt += list(dt)
        all_e += list(e)
    if all_dt:
        dmin, dmax = min(all_dt), max(all_dt)
        x = np.array([dmin, dmax])
        emax = max(all_e)
        for p, txt in ((1, "order 1"), (4, "order 4")):
            y = emax * 3 * (x / dmax) ** p
            ax.loglog(x, y, ":", color="0.4", lw=1)
            ax.annotate(txt, (x[0], y[0]), fontsize=7, color="0.3", xytext=(2, 2), textcoords="offset points")
        floor = data.get("order_floor", 1e-12)
        ax.axhspan(1e-17, floor, color="0.85", alpha=0.5, lw=0)
        ax.axhline(floor, color="0.5", lw=0.8)
        ax.set_ylim(max(min(all_e) / 3, 1e-17), min(emax * 30, 10))
    ax.set_xlabel("step Δt [s]")
    ax.set_ylabel("attitude error at t = T [rad]")
    ax.set_title(f"{data['scenario']}: convergence ({data['reference']} reference)", loc="left")
    handles, labels = ax.get_legend_handles_labels()
    more = cost.get_legend_handles_labels()  # the adaptive methods, drawn on the right only
    side_legend(cost, handles + more[0], labels + more[1])
    return fig


def side_legend(ax, handles=None, labels=None, *, loc: str = "center", down_to=None) -> None:
    """A legend to the right of ``ax`` (beside the figure's fixed right margin, :func:`subplots`), its entries
    centred on the axes' height (``loc="center"``) or from its top (``"upper"``): each a short line in the handle's
    style with its marker, and its label, placed in the figure's coordinates. matplotlib's own legend lays each
    entry out in boxes that it measures at every drawing: a third of a report's figure time, where these are a few
    lines and texts placed once. Rows shrink to fit where there are more than the height holds: the height of ``ax``
    and down to the bottom of the axes ``down_to`` (panels stacked below it) where given."""
    from matplotlib.lines import Line2D

    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    fig = ax.figure
    size = matplotlib.rcParams["legend.fontsize"]
    size = size if isinstance(size, (int, float)) else 7.0
    width, height = fig.get_size_inches()
    box = ax.get_position()
    if down_to is not None:
        box = matplotlib.transforms.Bbox.from_extents(box.x0, down_to.get_position().y0, box.x1, box.y1)
    pitch = min(1.3 * size / 72 / height, box.height / len(handles))  # figure fraction a row
    x0 = box.x1 + 0.01 * box.width + 0.4 * size / 72 / width
    x1 = x0 + 2.0 * size / 72 / width
    top = (box.y0 + box.y1) / 2 + pitch * (len(handles) - 1) / 2 if loc == "center" else box.y1 - pitch / 2
    for k, (h, label) in enumerate(zip(handles, labels)):
        y = top - k * pitch
        line = Line2D([x0, (x0 + x1) / 2, x1], [y, y, y], transform=fig.transFigure, color=h.get_color(),
                      linestyle=h.get_linestyle(), linewidth=h.get_linewidth(), marker=h.get_marker(),
                      markersize=h.get_markersize(), markerfacecolor=h.get_markerfacecolor(),
                      markeredgecolor=h.get_markeredgecolor(), markevery=[1])
        fig.add_artist(line)
        fig.text(x1 + 0.8 * size / 72 / width, y, label, fontsize=size, va="center", ha="left")


def line_style(name):
    return RUNNERS[name].line_style if name in RUNNERS else "-"


def _adaptive(entry) -> bool:
    return any(r.get("rtol") is not None for r in entry["runs"])


def _work_precision(ax, data, colors):
    """Error against the wall time of a run (the best of its timed repeats), every method joined step to step,
    an adaptive method tolerance to tolerance (open markers)."""
    for i, (name, entry) in enumerate(data["methods"].items()):
        runs = [r for r in entry["runs"] if r["attitude_error"] is not None and r.get("wall_time")]
        if not runs:
            continue
        adaptive = _adaptive(entry)
        runs.sort(key=lambda r: r["rtol"] if adaptive else r["dt"])
        ax.loglog([r["wall_time"] for r in runs], [max(r["attitude_error"], 1e-17) for r in runs], line_style(name),
                  marker=_MARKERS[i % len(_MARKERS)], ms=4, lw=1.2, color=colors[name],
                  mfc="white" if adaptive else colors[name], label=f"{name} (adaptive)" if adaptive else None)
    for tol in (1e-3, 1e-6, 1e-9):
        ax.axhline(tol, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("wall time of one run [s]")
    ax.set_title("work against precision", loc="right")


def _comparisons(data, colors):
    fig, ax = subplots(size=(7.5, 3.6), legend_outside=True)
    pairs = {}
    for c in data["comparisons"]:
        pairs.setdefault((c["a"], c["b"]), []).append((c["dt"], c["max_attitude_difference"]))
    for i, ((a, b), points) in enumerate(pairs.items()):
        points.sort()
        ax.loglog([p[0] for p in points], [max(p[1], 1e-17) for p in points], line_style(a),
                  marker=_MARKERS[i % len(_MARKERS)], ms=4, lw=1.2, color=colors.get(a), label=f"{a} − {b}")
    ax.set_xlabel("step Δt [s]")
    ax.set_ylabel("max attitude difference [rad]")
    ax.set_title(f"{data['scenario']}: engines against ours, trajectory to trajectory")
    side_legend(ax)
    return fig


def _drift_style(change) -> str:
    """An invariant's line: solid where the method gains (its largest change is positive), dashed where it damps."""
    return "--" if largest_change(change) < 0 else "-"


def _errors_in_time(series, colors, torque_free: bool):
    """Attitude error against time; torque free, below it the invariants kept apart (shared time axis): the energy's
    and |L|'s relative changes, their magnitude on log axes, solid where the method gained and dashed where it damped
    (the sign of its largest change), and the angle L's direction turned where it is kept."""
    turn = torque_free and any(s.get("momentum_turn") is not None for s in series.values())
    below = 2 + turn if torque_free else 0  # the invariants' panels, lower than the attitude's
    fig, axes = subplots(1 + below, size=(7.5, 3.6 + 1.25 * below), legend_outside=True, sharex=True,
                         gridspec_kw={"height_ratios": [2.4] + [1.25] * below})
    axes = np.atleast_1d(axes)
    for name, s in series.items():
        e = np.maximum(np.asarray(s["attitude_error"], float), 1e-17)
        axes[0].semilogy(s["t"], e, lw=1, color=colors.get(name), label=f"{name} (Δt = {step_label(s['dt'])} s)")
        if not torque_free:
            continue
        for ax, key in zip(axes[1:], ("energy_change", "momentum_change", "momentum_turn")):
            if s.get(key) is not None:
                y = np.asarray(s[key], dtype=float)
                ax.semilogy(s["t"], np.maximum(np.abs(y), 1e-18), _drift_style(y), lw=1, color=colors.get(name))
    axes[0].set_ylabel("attitude error [rad]")
    if torque_free:  # what is kept: a top's energy has its potential, its momentum is the vertical's component
        first = next(iter(series.values()), {})
        axes[1].set_ylabel(f"|{first.get('energy_label', LABELS['energy'])}|", fontsize=8)
        axes[2].set_ylabel(f"|{first.get('momentum_label', LABELS['momentum'])}|", fontsize=8)
        axes[1].set_title("solid: the method gains, dashed: it damps", loc="left", fontsize=8)
        if turn:
            axes[3].set_ylabel("L's direction\nturned [rad]", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    side_legend(axes[0], loc="upper", down_to=axes[-1])  # one method a row, beside every panel
    return fig


def _quaternion_method(series):
    for m in ("lie-rkmk4", "formulation-2", "formulation-1", "mujoco-rk4"):
        if m in series:
            return m
    return next(iter(series), None)


def _euler_histories(data, series, name):
    """Seed 001 Figs. 13-23: Euler angles from the Euler-angle run and converted from a quaternion run,
    their rates, the body rates and the quaternion components."""
    seq = data["initial"].get("euler_sequence", "323")
    qm = _quaternion_method(series)
    figs = []
    if qm is None:
        return figs
    sq = series[qm]
    ang_q = rot.quat_to_euler(sq["q"], seq, warn=False)
    ang_q = np.unwrap(ang_q, axis=0)
    labels = [f"angle {k + 1} (axis {seq[k]})" for k in range(3)] if seq != "323" else ["ψ", "θ", "φ"]
    se = series.get("euler-rk4")
    fig, axes = subplots(3, size=(7.5, 6.0), sharex=True)
    for k, ax in enumerate(axes):
        ax.plot(sq["t"], np.degrees(ang_q[:, k]), lw=1.2, label=f"from {qm} (quaternions)")
        if se is not None and "euler" in se:
            ax.plot(se["t"], np.degrees(se["euler"][:, k]), "--", lw=1.2, label="euler-rk4 (Euler angles)")
        ax.set_ylabel(f"{labels[k]} [deg]")
    axes[0].legend(frameon=False)
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(f"{name}: Euler angles ({seq}), like seed 001 Figs. 13-15")
    figs.append(png_of(fig, f"{name}-euler-angles.png",
                      "Euler angles from the Euler-angle integration and converted from the quaternion one "
                      "(seed 001 Figs. 13-15). Near the singularity the Euler-angle solution departs."))
    # rates of the angles
    fig, axes = subplots(3, size=(7.5, 6.0), sharex=True)
    rates_q = _safe_rates(ang_q, sq["omega"], seq)
    for k, ax in enumerate(axes):
        ax.plot(sq["t"], rates_q[:, k], lw=1.2, label=f"from {qm}")
        if se is not None and "euler" in se:
            ax.plot(se["t"], _safe_rates(se["euler"], se["omega"], seq)[:, k], "--", lw=1.2, label="euler-rk4")
        ax.set_ylabel(f"d{labels[k]}/dt [rad/s]")
    axes[0].legend(frameon=False)
    axes[-1].set_xlabel("t [s]")
    figs.append(png_of(fig, f"{name}-euler-rates.png",
                      "Rates of the Euler angles (seed 001 Figs. 16-18); undefined (gaps) at the singularity."))
    # body rates and quaternion components
    fig, (a1, a2) = subplots(2, size=(7.5, 5.2), sharex=True)
    for k, c in enumerate("xyz"):
        a1.plot(sq["t"], sq["omega"][:, k], lw=1.1, label=f"ω{c}")
    a1.set_ylabel("body rate [rad/s]")
    a1.legend(frameon=False, ncol=3)
    for k, c in enumerate("wxyz"):
        a2.plot(sq["t"], sq["q"][:, k], lw=1.1, label=f"q{c}")
    a2.set_ylabel(f"quaternion ({qm})")
    a2.set_xlabel("t [s]")
    a2.legend(frameon=False, ncol=4)
    figs.append(png_of(fig, f"{name}-rates-quaternion.png",
                      "Body rates and quaternion components (seed 001 Figs. 19-23): smooth, with no singularity."))
    return figs


def _safe_rates(angles, omega, seq):
    """Euler-angle rates for plotting: NaN (a gap in the line) where the sequence is singular."""
    J = rot.euler_rate_matrix(angles, seq)
    det = np.linalg.det(J)
    good = np.abs(det) > 1e-6
    out = np.full(np.shape(angles), np.nan)
    if np.any(good):
        out[good] = np.linalg.solve(J[good], np.asarray(omega)[good][..., None])[..., 0]
    return out


def _torqued_histories(data, series, name):
    """Seed 004 Figs. 9-11: torque components, quaternion components, body rates in deg/s."""
    qm = _quaternion_method(series)
    figs = []
    if qm is None:
        return figs
    s = series[qm]
    fig, axes = subplots(3, size=(7.5, 7.0), sharex=True)
    if "torque" in s:
        for k, c in enumerate("ξηζ"):
            axes[0].plot(s["t"], s["torque"][:, k] * 1e4, lw=1.1, label=f"t'{c}")
        axes[0].set_ylabel("torque [1e-4 N m]")
        axes[0].legend(frameon=False, ncol=3)
    for k, c in enumerate("0123"):
        axes[1].plot(s["t"], s["q"][:, k], lw=1.1, label=f"e{c}")
    axes[1].set_ylabel("Euler parameters")
    axes[1].legend(frameon=False, ncol=4)
    for k, c in enumerate("ξηζ"):
        axes[2].plot(s["t"], np.degrees(s["omega"][:, k]), lw=1.1, label=f"ω{c}")
    axes[2].set_ylabel("body rate [deg/s]")
    axes[2].set_xlabel("t [s]")
    axes[2].legend(frameon=False, ncol=3)
    axes[0].set_title(f"{name}: {qm}, Δt = {s['dt']:.3g} s (like seed 004 Figs. 9-11)")
    figs.append(png_of(fig, f"{name}-histories.png",
                      "Torque, Euler parameters and body rates in body components (seed 004 Figs. 9-11)."))
    return figs


def horizon_figure(doc: dict):
    """The horizon study (``xcheck horizon``'s JSON, schema xcheck.horizon/2): attitude error against time on log-log
    axes, one panel per step, each method a line; below, the relative energy drift where the motion keeps one."""
    steps = doc["steps"]
    lines = [line for line in doc["lines"] if line["status"] == "ok"]
    energy = any(line["energy_change"] is not None for line in lines)
    names = list(dict.fromkeys(line["method"] for line in doc["lines"]))
    colors = colors_of(names)
    fig, axes = subplots(2 if energy else 1, len(steps), size=(4.2 * len(steps) + 2.5, 7.4 if energy else 4.2),
                         legend_outside=True, sharex=True, sharey="row", squeeze=False)
    for col, dt in enumerate(steps):
        top = axes[0, col]
        for line in (x for x in lines if x["dt"] == dt):
            t = np.asarray(line["t"], dtype=float)
            top.loglog(t, np.maximum(np.asarray(line["attitude_error"], dtype=float), 1e-17),
                       line_style(line["method"]), lw=1.2, color=colors[line["method"]], label=line["method"])
            if energy and line["energy_change"] is not None:  # solid: gains, dashed: damps (line_style's)
                y = np.asarray(line["energy_change"], dtype=float)
                axes[1, col].loglog(t, np.maximum(np.abs(y), 1e-17), _drift_style(y), lw=1.2,
                                    color=colors[line["method"]])
        for bound in (1e-6, 1e-3):
            top.axhline(bound, color="0.5", lw=0.8, ls=":")
        top.set_title((f"{doc['scenario']} over {doc['duration']:g} s ({doc['reference']} reference)\n" if col == 0
                       else "\n") + f"Δt = {step_label(dt)} s", loc="left")
        axes[-1, col].set_xlabel("t [s]")
    axes[0, 0].set_ylabel("attitude error [rad]")
    if energy:
        axes[1, 0].set_ylabel("|E/E₀ − 1|")
        axes[1, 0].set_title("solid: the method gains energy, dashed: it damps", loc="left", fontsize=8)
    fig.subplots_adjust(top=1 - 0.6 / fig.get_size_inches()[1])  # the two-line titles
    side_legend(axes[0, -1], *_unique_handles(axes[0]), loc="upper")
    return fig


def _unique_handles(axes):
    """The lines of a row of axes, one a label (the first drawn)."""
    seen = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(label, h)
    return list(seen.values()), list(seen)
