"""Scoring a trajectory file against a scenario's reference: one run of some simulator, so no order — its attitude
and rate errors over time, how the attitude error grows (the exponent ``p`` of ``error ~ t^p``), the invariants of a
torque-free body computed from its samples, a verdict by its tolerance, and the detective's findings when it fails.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import rotations as rot
from ..invariants import invariant_series
from .convention import Convention, to_world
from .detective import EXPLAINS, investigate
from .earth import Earth
from .reader import TrajectoryFileError, read_samples

__all__ = ["FileScore", "score_file", "read_file", "growth_exponent", "PLOT_POINTS", "KEPT_ROWS"]

#: Points of a file's error series kept for the figures (spread evenly in log time).
PLOT_POINTS = 200


@dataclass
class FileScore:
    """What a trajectory file scored (JSON: :meth:`to_json`). Errors against the reference: the attitude [rad], the
    body rate [rad/s] (None without rates); drifts relative (energy, the momentum's magnitude in the world; None
    without rates or with a torque); ``growth``: the exponent of the attitude error's growth over the last nine
    tenths of the run (None when it stays at rounding); ``outcome`` PASSED or FAILED against ``tolerance`` (and
    ``rate_tolerance``); ``findings``: the detective's readings that explain a failure (best first), and
    ``tried``: how many it tried; ``series``: times and errors for the figures."""

    name: str
    file: str
    convention: str
    rows: int
    span: tuple
    max_attitude_error: float
    final_attitude_error: float
    max_rate_error: float | None
    growth: float | None
    #: the invariants' largest changes over the file's samples, torque free (:mod:`xcheck.invariants`): the energy's
    #: and |L|'s relative and signed (+ gained, - damped), the angle [rad] L's direction turned; None otherwise
    energy_change: float | None
    momentum_change: float | None
    momentum_turn: float | None
    tolerance: float
    rate_tolerance: float | None
    outcome: str
    source: str = ""
    findings: list = field(default_factory=list)
    best_reading: dict | None = None
    tried: int = 0
    notes: list = field(default_factory=list)
    series: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return self.outcome == "PASSED"

    def sentence(self) -> str:
        """The verdict and the detective's word in one sentence."""
        head = (f"{self.name}: largest attitude error {self.max_attitude_error:.3g} rad"
                + (f", rate error {self.max_rate_error:.3g} rad/s" if self.max_rate_error is not None else "")
                + f" ({self.outcome} against {self.tolerance:g} rad"
                + (f" and {self.rate_tolerance:.2g} rad/s)" if self.rate_tolerance is not None else ")"))
        if self.findings:
            f = self.findings[0]
            what = "rates" if f["judged"] == "rates" else "attitudes"
            err = f["max_rate_error"] if f["judged"] == "rates" else f["max_attitude_error"]
            unit = "rad/s" if f["judged"] == "rates" else "rad"
            return f"{head}; this file's {what} match the reference to {err:.2g} {unit} {f['change']}"
        if self.best_reading is not None:
            b = self.best_reading
            if b["max_attitude_error"] >= 0.5 * self.max_attitude_error:
                return f"{head}; none of the {self.tried} usual convention mistakes explains it, or halves it"
            return (f"{head}; none of the {self.tried} usual convention mistakes explains it (the closest, "
                    f"{b['change']}, leaves {b['max_attitude_error']:.3g} rad)")
        return head

    def to_json(self) -> dict:
        out = {k: getattr(self, k) for k in ("name", "file", "convention", "rows", "max_attitude_error",
                                             "final_attitude_error", "max_rate_error", "growth", "energy_change",
                                             "momentum_change", "momentum_turn", "tolerance", "rate_tolerance",
                                             "outcome", "tried")}
        out["span"] = list(self.span)
        out["sentence"] = self.sentence()
        for key in ("source", "findings", "best_reading", "notes"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        out["series"] = {k: [None if not np.isfinite(v) else float(f"{v:.4g}") for v in np.asarray(x, dtype=float)]
                         for k, x in self.series.items()}  # for the figure: about PLOT_POINTS points in log time
        return out


def growth_exponent(t, err, *, floor: float = 1e-15) -> float | None:
    """The exponent ``p`` of ``err ~ t^p`` fitted (least squares in log-log) over the samples after a tenth of the
    span where the error is above ``floor``; None with fewer than ten such samples."""
    t, err = np.asarray(t, dtype=float), np.asarray(err, dtype=float)
    keep = (t >= t[-1] / 10) & (t > 0) & (err > floor)
    if keep.sum() < 10:
        return None
    p = np.polyfit(np.log(t[keep]), np.log(err[keep]), 1)[0]
    return float(p)


def _log_spread(t, n: int) -> np.ndarray:
    """Indices of about ``n`` samples of ``t`` spread evenly in log time (the first and last kept)."""
    if len(t) <= n:
        return np.arange(len(t))
    positive = t[t > 0]
    start = positive[0] if len(positive) else 1.0
    marks = np.geomspace(start, max(t[-1], start), n)
    idx = np.unique(np.clip(np.searchsorted(t, marks), 0, len(t) - 1))
    return np.unique(np.concatenate([[0], idx, [len(t) - 1]]))


_READ: dict = {}  # (conv, duration, earth, the file's size and time stamp) -> (Samples, Converted); see read_file
#: The rows of the files :func:`read_file` keeps read, in all (about 150 MB): a larger file is read again to be scored.
KEPT_ROWS = 2_000_000


def read_file(conv: Convention, *, duration: float, earth: Earth | None):
    """``(samples, world)``: ``conv``'s file read and checked (:func:`~xcheck.scoring.reader.read_samples`) and
    converted to xcheck's convention (:func:`~xcheck.scoring.convention.to_world`), or a
    :class:`~xcheck.scoring.reader.TrajectoryFileError` naming the file, the line and the column (exit 2). Kept for
    the process while the file is unchanged: a study reads its files before it runs (issue 64: a bad file refused
    before the work, not after it) and scores them after, reading each once."""
    try:
        stat = conv.file.stat()
        key = (conv, duration, earth, stat.st_size, stat.st_mtime_ns)
    except (OSError, TypeError):  # missing (read_samples says so) or unhashable: not kept
        key = None
    if key is not None and key in _READ:
        return _READ[key]
    samples = read_samples(conv, duration=duration)
    try:
        world = to_world(conv, samples.t, samples.attitude, samples.rates, earth=earth, where=str(conv.file),
                         lines=samples.lines)
    except ValueError as exc:  # a quaternion or matrix off the unit sphere, named by its line
        raise TrajectoryFileError(str(exc)) from None
    if key is not None:
        _READ[key] = (samples, world)
        while sum(len(w.t) for _, w in _READ.values()) > KEPT_ROWS and len(_READ) > 1:
            del _READ[next(iter(_READ))]  # the oldest first
    return samples, world


def score_file(conv: Convention, reference, *, inertia, duration: float, earth: Earth | None, tolerance: float,
               torque_free: bool) -> FileScore:
    """Score ``conv``'s file: ``reference(t) -> (q, omega, mask)`` the scenario's reference at any times (``mask``:
    where it is defined), ``inertia`` the body's, ``tolerance`` the default limit of the attitude error [rad]."""
    samples, world = read_file(conv, duration=duration, earth=earth)
    notes = [*world.notes, *_euler_notes(conv, samples)]
    q_ref, w_ref, mask = reference(world.t)
    if not mask.all():
        notes.append(f"{int((~mask).sum())} of {len(mask)} rows at times where the reference is not defined (a fine "
                     "reference's own grid): left out")
    att = np.full(len(world.t), np.nan)
    att[mask] = rot.attitude_error(world.q[mask], q_ref[mask])
    rate = None
    if world.omega is not None:
        rate = np.full(len(world.t), np.nan)
        rate[mask] = np.linalg.norm(world.omega[mask] - w_ref[mask], axis=1)
    tol = conv.tolerance or tolerance
    # the rates' limit, unless declared: the attitude's relative accuracy on the body's initial rate
    rate_tol = conv.rate_tolerance or tol * max(float(np.linalg.norm(w_ref[mask][0])), 1e-3)
    max_att = float(np.nanmax(att))
    max_rate = float(np.nanmax(rate)) if rate is not None else None
    passed = max_att <= tol and (max_rate is None or max_rate <= rate_tol)
    kept = {}
    if torque_free and world.omega is not None:  # the file's own samples' invariants, signed (+ gained, - damped)
        kept = invariant_series(inertia, world.q, world.omega).largest()
    keep = _log_spread(world.t, PLOT_POINTS)
    series = {"t": world.t[keep], "attitude_error": att[keep],
              **({"rate_error": rate[keep]} if rate is not None else {})}
    score = FileScore(name=conv.name, file=str(conv.file), convention=conv.describe(samples.rate_columns),
                      rows=len(world.t), span=(float(world.t[0]), float(world.t[-1])), max_attitude_error=max_att,
                      final_attitude_error=float(att[mask][-1]), max_rate_error=max_rate,
                      growth=growth_exponent(world.t[mask], att[mask]), energy_change=kept.get("energy_change"),
                      momentum_change=kept.get("momentum_change"), momentum_turn=kept.get("momentum_turn"),
                      tolerance=tol, rate_tolerance=rate_tol if rate is not None else None,
                      outcome="PASSED" if passed else "FAILED",
                      source=conv.source, notes=notes, series=series)
    if not passed:
        _investigate(score, conv, samples, reference, earth, tol, rate_tol)
    return score


def _investigate(score: FileScore, conv, samples, reference, earth, tol, rate_tol) -> None:
    findings, score.tried = investigate(conv, samples, reference, earth=earth)
    explained = []
    for f in findings:
        given = score.max_attitude_error if f.judged == "attitude" else score.max_rate_error
        limit = tol if f.judged == "attitude" else rate_tol
        if given and f.error is not None and f.error <= EXPLAINS * given and f.error <= limit:
            explained.append(f)
    explained.sort(key=lambda f: f.error / (score.max_attitude_error if f.judged == "attitude"
                                            else score.max_rate_error))
    score.findings = [f.to_json() for f in explained]
    attitude = [f for f in findings if f.judged == "attitude"]
    if not explained and attitude:
        score.best_reading = attitude[0].to_json()


def _euler_notes(conv: Convention, samples) -> list:
    """Rows near the Euler sequence's singularity: their outer angles are ill-conditioned, though the attitude they
    give is exact to the printed digits (so the file is scored, and this said)."""
    if conv.attitude != "euler":
        return []
    angles = np.radians(samples.attitude) if conv.angle_unit == "deg" else samples.attitude
    seq = conv.sequence
    middle = angles[:, 1]
    symmetric = seq[0] == seq[2]
    distance = np.abs(np.sin(middle)) if symmetric else np.abs(np.cos(middle))
    near = distance < 1e-3
    if not near.any():
        return []
    k = int(np.argmax(near))
    return [f"{int(near.sum())} row(s) within 1e-3 rad of the {seq} sequence's singularity (the first: line "
            f"{samples.lines[k]}): their outer angles are ill-conditioned, but the attitude they give is exact to the "
            "printed digits"]
