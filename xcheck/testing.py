"""Assertion helpers for hand-written tests, and the failure messages the pytest plugin prints (issue 13).

>>> from xcheck.testing import assert_converges, assert_matches_reference, assert_agrees, assert_invariants
>>> assert_converges("xcheck_my_body.toml", method="mujoco-rk4", order=4, tol=0.3)

Each helper runs what it needs in this process (no worker processes: safe under pytest-xdist, and MuJoCo's
process-global control callback is installed and restored around every run) and raises an
:class:`XcheckAssertionError` (an ``AssertionError``) whose message says what was measured, the limit, the
steps and the reference, and the report line that explains it.
"""

from __future__ import annotations

import math

__all__ = ["assert_converges", "assert_matches_reference", "assert_agrees", "assert_invariants",
           "XcheckAssertionError", "check_message", "check_outcome"]


class XcheckAssertionError(AssertionError):
    """A cross-check that did not hold; the message is complete (pytest shows it without a traceback)."""


def _scenario(scenario_or_path):
    from .scenario import Scenario, resolve_scenario

    return scenario_or_path if isinstance(scenario_or_path, Scenario) else resolve_scenario(scenario_or_path)


def _steps_text(steps) -> str:
    from .trajectory import step_label

    steps = sorted(steps, reverse=True)
    return f"{step_label(steps[0])} … {step_label(steps[-1])} s ({len(steps)} steps)" if len(steps) > 1 else \
        f"{step_label(steps[0])} s"


def _num(v) -> str:
    return "—" if v is None else f"{v:.3g}"


def method_line(study, method: str) -> str:
    """The report's line for one method: its finest good run's errors, its observed order, its runs that
    failed (the runs table and the order column of the report, in one line); a trajectory file's sentence."""
    from .trajectory import step_label

    if method not in study.methods:
        return f"report: {study.files[method].sentence()}" if method in study.files else f"report: {method}: not run"
    m = study.methods[method]
    parts = []
    if m.finest is not None:
        f = m.finest
        parts.append(f"at Δt = {step_label(f.dt)} s attitude error {_num(f.attitude_error)} rad (largest over the run "
                     f"{_num(f.max_attitude_error)} rad)")
    parts.append(f"observed order {_num(m.observed_order)}" + (f" ({m.order_note})" if m.order_note else ""))
    parts.append(statements_text(m))
    failed = [r for r in m.runs if not r.ok]
    if failed:
        parts.append("; ".join(f"Δt = {step_label(r.dt)} s {r.status}: {r.message}" for r in failed[:2]))
    return f"report: {method}: " + "; ".join(parts)


def statements_text(m) -> str:
    """A method's two statements in words (:mod:`xcheck.study.statements`): ``consistent: yes; accurate at 0.01 s:
    NO (1.9e-01 rad, tolerance 1e-06 rad); there energy -3.8e-02 ∝ t, |L| -1.9e-02 ∝ t, L turned 5.6e-03 rad``."""
    from .study.statements import invariants_text, where_text

    a = m.accurate
    out = f"consistent: {m.consistent}"
    if a is None:
        return out + "; accurate: — (no completed run)"
    what = f"{a['error']:.2g} rad" if a.get("error") is not None else a.get("status", "failed")
    out += (f"; accurate at {where_text(a)}{' (yours)' if a['yours'] else ''}: {'yes' if a['within'] else 'NO'} "
            f"({what}, tolerance {a['tolerance']:g} rad)")
    energy, size, turn = invariants_text(a)
    kept = [f"{name} {text}" for name, text in (("energy", energy), ("|L|", size)) if text != "—"]
    kept += [f"L turned {turn} rad"] if turn != "—" else []
    return out + (f"; there {', '.join(kept)}" if kept else "")


def check_message(study, method: str, kind: str) -> str | None:
    """Why the check ``kind`` of ``method`` failed in ``study`` (None when it passed): the measured value, the
    limit, the steps, the reference and the report's line for the method."""
    sc = study.scenario
    if any(c.kind == "reference" and not c.passed for c in study.checks):
        ref = next(c for c in study.checks if c.kind == "reference")
        return f"{sc.name}: nothing measured: {ref.note}"
    found = [c for c in study.checks if c.method == method and c.kind == kind]
    if kind == "runs" and not found:
        return None  # the runs check is made only when it fails
    if not found and kind == "order" and method in getattr(study, "over_budget", {}):
        left, why = study.over_budget[method]  # the steps that would decide its order were left out: no claim
        return f"{sc.name}: {method} order: not measured: {why}\n{method_line(study, method)}"
    if not found:
        return (f"{sc.name}: {method} {kind}: not measured (no run of {method} completed)\n"
                f"{method_line(study, method)}")
    check = found[0]
    if check.passed:
        return None
    from .study.checks import check_summary

    if kind == "file" or method in study.files:  # a trajectory file: its sentence says it all
        return (f"{sc.name}: {method} {kind} FAILED: {check.note}\n"
                f"  the {study.reference_used} reference over {sc.duration:g} s; file {study.files[method].file}")
    if kind == "runs":
        measured = f"its finest run must complete: {check.note}"
    elif kind == "expected-failure":
        measured = f"expected to fail (the scenario's [checks] expected_to_fail): {check.note}"
    else:
        measured = check_summary(check, sc.checks)
    if check.known:
        return f"{sc.name}: {method} {kind} KNOWN: {check_summary(check, sc.checks)}; {check.known}"
    word = "INCONCLUSIVE" if check.inconclusive else "FAILED"
    return (f"{sc.name}: {method} {kind} {word}: {measured}\n"
            f"  steps {_steps_text(study.steps)}, {study.reference_used} reference, {sc.duration:g} s"
            + (f"; {check.note}" if check.note and kind not in ("runs", "expected-failure") and check.note != measured
               else "") + "\n"
            f"  {method_line(study, method)}")


def check_outcome(study, method: str, kind: str) -> tuple[str, str | None]:
    """``(status, message)`` of a check for a test item: ``pass`` (no message), ``fail``, ``inconclusive`` or ``known``
    (a known finding of the method's engine explains the failure) with the :func:`check_message`; a study that cannot decide at all (vacuous, a suspect reference: ``study.inconclusive``)
    makes its passing checks inconclusive too, saying why."""
    message = check_message(study, method, kind)
    found = [c for c in study.checks if c.method == method and c.kind == kind]
    if message is not None:
        undecided = not found and kind == "order" and method in getattr(study, "over_budget", {})
        return ("inconclusive" if undecided or found and found[0].inconclusive else
                "known" if found and found[0].known else "fail"), message
    if study.inconclusive and kind != "expected-failure":
        return "inconclusive", f"{study.scenario.name}: {method} {kind}: INCONCLUSIVE: {'; '.join(study.inconclusive)}"
    return "pass", None


# ------------------------------------------------------------------------------------------------------
def _study(scenario_or_path, methods, steps=None, quick=True):
    from .study import run_study

    sc = _scenario(scenario_or_path)
    return run_study(sc, methods=methods, steps=steps, quick=quick and steps is None, workers=1,
                     timing=False)  # the assertions read no wall time


def assert_converges(scenario_or_path, *, method: str, order: float | None = None, tol: float = 0.3, steps=None,
                     quick: bool = True):
    """The observed order of ``method`` on the scenario is ``order`` (default: the method's expected order)
    within ``tol``. Runs the scenario's quick steps (``quick``) or ``steps``. Returns the study."""
    from .runners import RUNNERS

    st = _study(scenario_or_path, [method], steps, quick)
    m = st.methods[method]
    want = order if order is not None else RUNNERS[method].expected_order
    if want is None:
        raise ValueError(f"order: {method} has no expected order; give order=")
    if m.observed_order is None or abs(m.observed_order - want) > tol:
        raise XcheckAssertionError(
            f"{st.name}: {method} does not converge at order {want} ± {tol}: observed {_num(m.observed_order)}\n"
            f"  steps {_steps_text(st.steps)}, {st.scenario.reference} reference\n  {method_line(st, method)}")
    return st


def assert_matches_reference(scenario_or_path, *, method: str, atol: float, dt: float | None = None):
    """The largest attitude error of ``method`` over the run, at ``dt`` (default: the scenario's finest quick
    step), against the scenario's reference is at most ``atol`` [rad]. Returns the run."""
    sc = _scenario(scenario_or_path)
    dt = dt if dt is not None else min(sc.quick_steps)
    st = _study(sc, [method], steps=[dt])
    run = st.methods[method].runs[0]
    if not run.ok or not run.max_attitude_error <= atol:
        got = f"{run.status}: {run.message}" if not run.ok else f"{run.max_attitude_error:.3g} rad"
        raise XcheckAssertionError(
            f"{sc.name}: {method} at Δt = {dt:g} s is not within {atol:g} rad of the {sc.reference} reference: "
            f"largest attitude error over the run {got} (at the end {_num(run.attitude_error)} rad)")
    return run


def assert_agrees(scenario_or_path, a: str, b: str, *, dt: float, atol: float):
    """Methods (or engines) ``a`` and ``b`` on the same scenario at the same step agree within ``atol`` [rad]:
    their largest attitude difference over the run, trajectory against trajectory (no reference). Returns it."""
    from . import rotations as rot
    from .runners import RUNNERS
    from .study.context import run_context

    sc = _scenario(scenario_or_path)
    for name in (a, b):
        if name not in RUNNERS:
            raise ValueError(f"method: unknown {name!r}; expected one of {', '.join(RUNNERS)}")
    ctx = run_context(sc)
    ta, tb = RUNNERS[a].run(ctx, dt), RUNNERS[b].run(ctx, dt)
    for name, t in ((a, ta), (b, tb)):
        if not t.ok:
            raise XcheckAssertionError(f"{sc.name}: {name} at Δt = {dt:g} s did not complete: {t.message}")
    diff = rot.attitude_error(ta.q, tb.q)
    worst = float(diff.max())
    if not worst <= atol:
        k = int(diff.argmax())
        raise XcheckAssertionError(
            f"{sc.name}: {a} and {b} at Δt = {dt:g} s differ by {worst:.3g} rad (at t = {ta.t[k]:.4g} s), more than "
            f"{atol:g} rad (trajectory against trajectory, no reference; at the end {diff[-1]:.3g} rad)")
    return worst


def assert_invariants(scenario_or_path, *, method: str, dt: float | None = None, rtol: float = 1e-9,
                      norm_atol: float = 1e-12):
    """A torque-free scenario keeps its kinetic energy, |L| and L's direction: over the run of ``method`` at ``dt``
    (default: the finest quick step) the largest relative change of the energy and of |L| (signed: + gained, -
    damped) and the angle [rad] L's direction turned are each at most ``rtol`` in magnitude, and the quaternion's
    norm stays within ``norm_atol`` of 1. Returns the changes (:func:`xcheck.metrics.invariant_changes`)."""
    from .metrics import invariant_changes
    from .runners import RUNNERS
    from .study.context import run_context

    sc = _scenario(scenario_or_path)
    if sc.torque is not None:
        raise ValueError(f"{sc.name}: has a [torque]: energy and momentum are not conserved; use a torque-free scenario")
    dt = dt if dt is not None else min(sc.quick_steps)
    ctx = run_context(sc)
    traj = RUNNERS[method].run(ctx, dt)
    if not traj.ok:
        raise XcheckAssertionError(f"{sc.name}: {method} at Δt = {dt:g} s did not complete: {traj.message}")
    changes = invariant_changes(ctx.inertia, traj)
    words = {"energy_change": ("energy", rtol, "{:+.3g}"), "momentum_change": ("|L|", rtol, "{:+.3g}"),
             "momentum_turn": ("L's direction turned", rtol, "{:.3g} rad"),
             "norm_drift": ("quaternion norm off 1 by", norm_atol, "{:.3g}")}

    def said(key, name, form):
        change = changes[key]
        signed = key in ("energy_change", "momentum_change") and change == change and change != 0
        return f"{name} {form.format(change)}" + ((" (gained)" if change > 0 else " (damped)") if signed else "")

    bad = [f"{said(k, name, form)}, beyond ±{lim:g}" for k, (name, lim, form) in words.items()
           if not (math.isfinite(changes[k]) and abs(changes[k]) <= lim)]
    if bad:
        raise XcheckAssertionError(f"{sc.name}: {method} at Δt = {dt:g} s over {sc.duration:g} s: " + "; ".join(bad))
    return changes
