"""What a cross-check found, as typed records computed once: a :class:`Run` (one method at one step),
:class:`MethodRuns` (a method's runs as a worker measured them), a :class:`MethodResult` (its runs, observed
order, finest good run and verdict) and a :class:`Check` (kind,
method, passed, value, limit, note). The JSON of schema ``xcheck.convergence/3`` is made from them at the edge
(``to_json``), with every key it has always had; ``verdict`` is new.

Verdicts: ``pass`` every check of the method passed; ``fail`` one failed (or the study's reference could not
be computed); ``expected`` the failure the scenario declares (``expected_to_fail``) happened, or a known finding of
the method's engine explains each of its failed checks (a check's status ``known``); ``inconclusive``
a check could not decide (its steps show no asymptotic range, its reference is suspect or less certain than its
limit) and none failed; ``info`` the method has no checks (reported only).

A study's outcome (:data:`OUTCOMES`, issue 36): ``FAILED`` when a check failed (a method disagrees with a
reference that is itself verified); else ``INCONCLUSIVE`` when a check could not decide or the study tests nothing
(a vacuous study: every method exact); else ``PASSED``. Exit codes 0, 1 and 4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

__all__ = ["Run", "MethodRuns", "Check", "OURS_EARLY", "MethodResult", "json_number", "VERDICTS", "OUTCOMES",
           "outcome_of", "outcome_value"]

VERDICTS = ("pass", "fail", "expected", "inconclusive", "info")
OUTCOMES = ("PASSED", "FAILED", "INCONCLUSIVE")


def outcome_of(outcomes) -> str:
    """The outcome of several (studies, sections): FAILED if any failed, else INCONCLUSIVE if any was, else PASSED."""
    outcomes = list(outcomes)
    return "FAILED" if "FAILED" in outcomes else "INCONCLUSIVE" if "INCONCLUSIVE" in outcomes else "PASSED"


def outcome_value(outcome: str) -> float:
    """An outcome as a number (the history's): 1 passed, 0.5 inconclusive, 0 failed."""
    return {"PASSED": 1.0, "INCONCLUSIVE": 0.5, "FAILED": 0.0}[outcome]


def json_number(v):
    """``v`` as a JSON number, or None (None, NaN and infinities have no JSON number)."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


#: A run's fields its JSON leaves out: its message (written only where there is one), its invariants' laws (see them)
_NOT_IN_JSON = ("message", "energy_law", "momentum_law", "turn_law", "flips", "precession")


@dataclass
class Run:
    """One run of one method at one step (an adaptive method's: at one relative tolerance ``rtol``, with ``dt`` its
    output step). Errors are against the reference at the final time (``attitude_error`` [rad], ``omega_error``
    [rad/s]) and their maxima over the run; the invariants' changes are signed (see the fields) and the quaternion norm's drift absolute;
    ``None`` where not measured (a failed run, a torqued scenario's invariants). ``wall_time`` [s] is the best of
    ``repeats`` runs (short runs are repeated until a small budget is spent); ``evaluations`` the right-hand-side
    (or engine stage) evaluations of one run, a measure of work that does not depend on the machine (None where
    the engine does not report it)."""

    dt: float
    status: str = "ok"  # "ok" | "singular" | "failed"
    message: str = ""
    attitude_error: float | None = None
    max_attitude_error: float | None = None
    omega_error: float | None = None
    max_omega_error: float | None = None
    #: the invariants' largest changes over the run (:mod:`xcheck.invariants`): the energy's and |L|'s relative and
    #: signed (positive: the method gained, negative: it damped), the angle [rad] L's direction turned; a symmetric
    #: top's spin momentum about its axis relative to |L0|, signed; None where the motion does not keep it
    energy_change: float | None = None
    momentum_change: float | None = None
    momentum_turn: float | None = None
    spin_change: float | None = None
    #: each one's law over the run with its direction ("gains ∝ t", "damps ∝ t^0.52", "bounded oscillation",
    #: "round-off": :func:`xcheck.invariants.law_text`), None where not kept; in the JSON of the run a method's
    #: accuracy is judged at (its ``accurate``) and of the user's step (``your_step``), not of every run (a quick
    #: report's results.json would grow by a fifth)
    energy_law: str | None = None
    momentum_law: str | None = None
    turn_law: str | None = None
    #: a gyrostat's largest wheel-speed error over the run [rad/s], relative to the body (an engine's own wheels,
    #: ours from the wheels' momentum and the body rate); None without wheels
    wheel_speed_error: float | None = None
    norm_drift: float | None = None
    wall_time: float | None = None
    steps_per_second: float | None = None
    repeats: int | None = None
    evaluations: int | None = None
    rtol: float | None = None
    #: a tumbling body's flips over the run (:func:`xcheck.motion.flips_of`: ``flips``, ``first`` [s], ``every``
    #: [s]), None where the body does not tumble; like the laws, in the JSON of the runs the answers quote only
    flips: dict | None = None
    #: a top's or an axisymmetric body's cone over the run (:func:`xcheck.motion.precession_of`: ``precession``
    #: [rad/s], ``nutation_period`` [s], ``nutations``), None for any other body; in the same JSON as ``flips``
    precession: dict | None = None
    #: the LGVI's steps taken as substeps, its equation having no solution at the run's step (issue 63; the run's
    #: message says how many substeps); None where none was: such a run is left out of the method's order
    substeps: int | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def setting(self) -> float:
        """What a study varies: the step, or an adaptive method's tolerance (finer: smaller)."""
        return self.dt if self.rtol is None else self.rtol

    @classmethod
    def failed(cls, dt, status, message, wall_time, rtol=None) -> "Run":
        return cls(dt=dt, status=status, message=message, wall_time=wall_time, rtol=rtol)

    def to_json(self) -> dict:
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in _NOT_IN_JSON
               and not (f.name in ("rtol", "spin_change", "wheel_speed_error", "substeps")
                        and getattr(self, f.name) is None)}
        if not self.ok or self.message:  # a failure's reason, or a good run's note (an engine's rounded clock)
            out["message"] = self.message
        return out


@dataclass
class MethodRuns:
    """One method's runs in one scenario as a worker measured them, what :func:`xcheck.study.assemble` takes (a
    study's worker and a sweep's chunk both make them): the runs (coarse to fine, or loose to tight
    tolerances), the finest good run sampled for the figures (``series``; None where none is drawn), the direct
    comparisons with its partner, why nothing could be measured (``reference_error``), what the guard of an exact
    reference found (``reference_check``: :meth:`xcheck.guard.ReferenceCheck.to_json` and its sentence), and
    whether a sweep ran it batched."""

    method: str
    runs: list
    series: dict | None = None
    comparisons: list = field(default_factory=list)
    reference_error: str | None = None
    batched: bool = False
    reference_check: dict | None = None
    #: the method's engine could not be imported in the worker (a broken install): why; nothing was run
    import_error: str | None = None
    #: the reference's own flips where the body tumbles (:func:`xcheck.motion.flip_summary`), None elsewhere
    reference_flips: dict | None = None
    #: the reference's own precession and nutation (:func:`xcheck.motion.precession_summary`), None elsewhere
    reference_precession: dict | None = None
    #: what the method's engine was given for the body (:mod:`xcheck.engines.built`: ``{"body", "engine"}``), None:
    #: an engine not known there
    built: dict | None = None

    @classmethod
    def without_reference(cls, method: str, settings, reason: str) -> "MethodRuns":
        """Every run of ``settings`` (``(dt, rtol)`` pairs) failed for want of a reference (``reason``)."""
        return cls(method, [Run.failed(dt, "failed", f"no reference: {reason}", 0.0, rtol) for dt, rtol in settings],
                   reference_error=str(reason))


#: The ``known`` of an order check of one of xcheck's own methods that is pre-asymptotic at the study's steps (issue
#: 63): left out of the verdict, as an engine's known finding is, but no finding (:attr:`Check.left_out`).
OURS_EARLY = ("one of xcheck's own methods, pre-asymptotic at these steps: left out of the verdict (a method of ours "
              "is the study's yardstick, not its subject; the engines' and the reference decide)")


@dataclass
class Check:
    """One check of a study: ``kind`` (order, final-error, invariants, runs, agreement, expected-failure,
    reference), the ``method`` it is about (None for the study as a whole), and what it measured. ``inconclusive``:
    it could not decide (not passed, not failed); ``note`` says why and what would decide it."""

    kind: str
    passed: bool
    method: str | None = None
    value: float | None = None
    limit: float | None = None
    note: str = ""
    inconclusive: bool = False
    #: a known finding of the method's engine explains this failure (:attr:`xcheck.runners.Runner.known`): what it
    #: is, with the numbers that show it at work here; the check is then neither passed nor failed, but ``known``
    known: str = ""

    @property
    def name(self) -> str:
        return f"{self.kind}:{self.method}" if self.method else self.kind

    @property
    def status(self) -> str:
        """``pass``, ``fail``, ``inconclusive`` or ``known``."""
        return "pass" if self.passed else "inconclusive" if self.inconclusive else "known" if self.known else "fail"

    @property
    def failed(self) -> bool:
        return not self.passed and not self.inconclusive and not self.known

    @property
    def left_out(self) -> bool:
        """One of xcheck's own methods pre-asymptotic here, left out of the verdict (:data:`OURS_EARLY`)."""
        return self.known == OURS_EARLY

    def to_json(self) -> dict:
        return {"name": self.name, "passed": bool(self.passed), "status": self.status, "value": json_number(self.value),
                "limit": json_number(self.limit), "note": self.note, **({"known": self.known} if self.known else {})}


@dataclass
class MethodResult:
    """One method of a study: its runs from coarse to fine, the observed order, and the verdict."""

    name: str
    engine: str
    expected_order: int | None
    runs: list = field(default_factory=list)
    observed_order: float | None = None
    order_note: str = ""
    local_orders: list = field(default_factory=list)
    verdict: str = "info"
    within: dict = field(default_factory=dict)  # tolerance key ("1e-06") -> metrics.StepWithin
    #: the two statements of its row (:mod:`xcheck.study.statements`): whether it behaves as its theory says
    #: ("yes", "no", "undecided", ...), and whether it is within the tolerance at the step named (a dict; None
    #: without a completed run)
    consistent: str = "—"
    accurate: dict | None = None

    @property
    def status(self) -> str:
        """``ok`` (every run), ``singular`` (a run reached a parametrization's singularity) or ``failed``."""
        if all(r.ok for r in self.runs):
            return "ok"
        return "singular" if any(r.status == "singular" for r in self.runs) else "failed"

    @property
    def status_text(self) -> str:
        """The status in words for a table: a method whose verdict holds although a coarse step failed says
        so ("coarse step unstable"), instead of a bare "failed"."""
        if self.status != "ok" and self.verdict in ("pass", "info") and self.finest is not None:
            return "coarse step singular" if self.status == "singular" else "coarse step unstable"
        return self.status

    @property
    def adaptive(self) -> bool:
        """Whether the runs are a ladder of tolerances (an adaptive method) rather than of steps."""
        return any(r.rtol is not None for r in self.runs)

    @property
    def finest(self) -> Run | None:
        """The completed run at the finest step (an adaptive method's: at the tightest tolerance), or None."""
        ok = [r for r in self.runs if r.ok]
        return min(ok, key=lambda r: r.setting) if ok else None

    def to_json(self) -> dict:
        return {"engine": self.engine, "expected_order": self.expected_order, "observed_order": self.observed_order,
                "order_note": self.order_note, "local_orders": self.local_orders, "status": self.status,
                "runs": [r.to_json() for r in self.runs], "verdict": self.verdict, "consistent": self.consistent,
                "accurate": self.accurate,
                "largest_step_within": {k: w.dt for k, w in self.within.items()},
                **({"loosest_tolerance_within": {k: w.rtol for k, w in self.within.items()}} if self.adaptive else {}),
                "cost_within": {k: w.to_json() for k, w in self.within.items()}}
