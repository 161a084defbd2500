"""Two statements per method, never one word for both (issue 60): whether it is **consistent** — behaves as its theory
says: it completes at its finest step, shows its order, keeps what it should — and whether it is **accurate** — its
largest attitude error over the run is within the user's tolerance at the step the row names (the user's own step where
the study ran it, else the method's finest). A first-order method can be perfectly consistent and 0.2 rad off at the
user's step: the row says both, and no row says a bare "ok" beside an error above the tolerance.

``consistent`` is one of :data:`CONSISTENT` (from the method's checks of kinds :data:`THEORY`); ``accurate`` a dict:
``dt`` [s] (or an adaptive method's tightest ``rtol``), ``yours`` (the user's step), ``error`` [rad], ``tolerance``
[rad], ``within`` (bool), and the run's invariants there (:mod:`xcheck.invariants`). Both are in the JSON of every
method (schema ``xcheck.convergence/3``), the terminal's table and the report's."""

from __future__ import annotations

from ..defaults import DEFAULT_CHECKS
from ..invariants import RUN_KEYS, change_text
from ..trajectory import same_step, step_label

__all__ = ["flip_rows", "precession_rows", "motion_of", "consistency", "accuracy", "usual_place", "CONSISTENT",
           "THEORY", "short_law", "where_text", "accurate_text", "invariants_text"]

#: The checks that say whether a method behaves as its theory says (the rest judge accuracy: final-error, agreement).
THEORY = ("runs", "order", "invariants", "expected-failure")
#: What ``consistent`` can say: its checks of :data:`THEORY` passed, one failed, one could not decide, a known finding
#: of its engine explains the failure, one of xcheck's own methods is pre-asymptotic at the study's steps (left out of
#: the verdict), the scenario expects it to fail, or there is nothing to check (an adaptive method has no order).
CONSISTENT = ("yes", "no", "undecided", "known finding", "pre-asymptotic", "expected to fail", "—")


def motion_of(run) -> dict:
    """A run's motion numbers (:mod:`xcheck.motion`) for the answers that quote it: its ``flips`` and its
    ``precession`` where measured, nothing else."""
    return {key: getattr(run, key) for key in ("flips", "precession") if getattr(run, key)}


def consistency(method: str, checks) -> str:
    """Whether ``method`` behaves as its theory says, from its ``checks`` of kinds :data:`THEORY` (see
    :data:`CONSISTENT`)."""
    related = [c for c in checks if c.method == method and c.kind in THEORY]
    if any(c.kind == "expected-failure" for c in related):
        return "expected to fail"
    if any(c.failed and not c.known for c in related):
        return "no"
    if any(c.known for c in related):
        return "pre-asymptotic" if all(c.left_out for c in related if c.known) else "known finding"
    if any(c.inconclusive for c in related):
        return "undecided"
    return "yes" if related else "—"


def accuracy(m, your_step: dict | None, tolerance: float | None = None) -> dict | None:
    """Whether method ``m`` (a :class:`~xcheck.results.MethodResult`) is within the tolerance at the user's step
    (``your_step``: :func:`~xcheck.study.your_step.your_step_answer`'s, whose entry for it is read where the study ran
    it there) or else at its finest run; None without a completed run there. ``tolerance`` [rad]: ``your_step``'s,
    else ``tolerance``, else :data:`DEFAULT_CHECKS`'s."""
    if your_step and your_step["studied"] and not m.adaptive:
        tol = your_step["tolerance"]
        if m.name in your_step["methods"]:
            return {"dt": your_step["dt"], "yours": True, "tolerance": tol, **your_step["methods"][m.name]}
        run = next((r for r in m.runs if same_step(r.dt, your_step["dt"])), None)
        if run is not None:  # it ran at the user's step and did not complete
            return {"dt": run.dt, "yours": True, "error": None, "tolerance": tol, "within": False,
                    "status": run.status}
    tol = float(tolerance if tolerance is not None else
                your_step["tolerance"] if your_step else DEFAULT_CHECKS["tolerance"])
    run = m.finest
    if run is None or run.max_attitude_error is None:
        return None
    return {"dt": run.dt, **({"rtol": run.rtol} if run.rtol is not None else {}), "yours": False,
            "error": run.max_attitude_error, "tolerance": tol, "within": run.max_attitude_error <= tol,
            **{key: getattr(run, key) for key in RUN_KEYS}, **motion_of(run)}


def usual_place(methods) -> str | None:
    """The step most of ``methods``' rows are judged at (:func:`where_text`): a row judged elsewhere says its step."""
    places = [where_text(m.accurate) for m in methods if m.accurate is not None]
    return max(set(places), key=places.count) if places else None


def short_law(law: str | None) -> str:
    """A law of :func:`xcheck.invariants.law_text` for a table cell beside its signed number (which says the
    direction): ``∝ t``, ``∝ t^0.46``, ``bounded``, ``round-off``, ``gone`` (damped away), ``runaway``."""
    if not law:
        return ""
    if law.startswith(("gains ∝", "damps ∝", "turns ∝")):
        return law.split(" ", 1)[1]
    return {"bounded oscillation": "bounded", "round-off": "round-off"}.get(
        law, "gone" if law.startswith("damped away") else "runaway" if law.startswith("gained") else law.split(" (")[0])


def where_text(a) -> str:
    """The step a row's accuracy is judged at, or a run's (``a`` a dict or a :class:`~xcheck.results.Run`): ``0.01 s``
    or an adaptive method's ``rtol 1e-10``."""
    dt, rtol = (a["dt"], a.get("rtol")) if isinstance(a, dict) else (a.dt, a.rtol)
    return f"rtol {rtol:.0e}" if rtol is not None else f"{step_label(dt)} s"


def accurate_text(a: dict | None, *, show_step: bool) -> str:
    """The accuracy statement of a row: ``yes (2.5e-09)``, ``NO (1.9e-01)``, ``NO (failed)``; with ``show_step`` (rows
    judged at different steps) ``NO (1.9e-01 at 1/4096 s)``; ``—`` without a completed run."""
    if a is None:
        return "—"
    what = a["status"] if a.get("error") is None else f"{a['error']:.1e}"
    at = f" at {where_text(a)}" if show_step else ""
    return f"{'yes' if a['within'] else 'NO'} ({what}{at})"


def invariants_text(a: dict | None) -> tuple[str, str, str]:
    """A row's energy, |L| and L-turn cells at its accuracy's step: ``+4.0e-02 ∝ t``, ``-2.3e-11 round-off``,
    ``7.1e-03``; ``—`` where not kept."""
    if a is None or a.get("error") is None:
        return "—", "—", "—"
    cells = [change_text(a.get(key), short_law(a.get(law)), digits=1)
             for key, law in (("energy_change", "energy_law"), ("momentum_change", "momentum_law"))]
    turn = a.get("momentum_turn")
    return cells[0], cells[1], "—" if turn is None else f"{turn:.1e}"


def flip_rows(st) -> tuple[str, list[tuple]] | None:
    """A tumbling body's flips (:mod:`xcheck.motion`) for a table, the terminal's and the report's: the sentence that
    heads it (what a flip is, the reference's), and per method whose row has them ``(name, step, flips, first, Δ
    first, every, Δ every)`` at the step its accuracy is judged at (times [s]; Δ the method's less the reference's,
    None where either has none); None where the body does not tumble."""
    if not st.flips:
        return None
    ref = st.flips["reference"]
    times = "once" if ref["flips"] == 1 else f"{ref['flips']} times"
    every = "" if ref["every"] is None else f", every {ref['every']:.6g} s"
    head = (f"flips (the body tumbles; a flip: its rate about the intermediate principal axis changes sign, placed "
            f"between samples): the reference flips {times} in {st.scenario.duration:g} s, first at "
            f"{ref['first']:.6g} s{every}; Δ = the method's less the reference's")
    rows = []
    for name, m in st.methods.items():
        f = (m.accurate or {}).get("flips")
        if f is not None:
            delta = {k: None if f[k] is None or ref[k] is None else f[k] - ref[k] for k in ("first", "every")}
            rows.append((name, where_text(m.accurate), f["flips"], f["first"], delta["first"], f["every"],
                         delta["every"]))
    return head, rows


def precession_rows(st) -> tuple[str, list[tuple]] | None:
    """A top's or an axisymmetric body's cone (:mod:`xcheck.motion`) for a table, as :func:`flip_rows`: the sentence
    (what is measured, the reference's) and per method ``(name, step, precession [rad/s], Δ, nutation period [s],
    Δ, the cone's change less the reference's [rad])`` at the step its accuracy is judged at (Δ against the
    reference at the run's own times: what the sampling costs both cancels); None where the body is neither."""
    if not st.precession:
        return None
    ref = st.precession["reference"]
    nutation = ("" if ref["nutation_period"] is None else
                f", nutation period {ref['nutation_period']:.6g} s ({ref['nutations']} periods measured)")
    head = (f"precession and nutation ({st.precession['how']}): the reference precesses at {ref['precession']:.6g} "
            f"rad/s{nutation}; Δ = the method's less the reference's measured the same way at the method's own times; "
            "cone Δ: how much more the cone between the axis and the pole widened (+) or narrowed (-) than the "
            "reference's, a wobble's decay")
    rows = []
    for name, m in st.methods.items():
        p = (m.accurate or {}).get("precession")
        if p is not None:
            rows.append((name, where_text(m.accurate), p["precession"], p["precession_error"], p["nutation_period"],
                         p["nutation_error"], p["cone_error"]))
    return head, rows
