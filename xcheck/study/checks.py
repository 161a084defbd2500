"""The checks of a study, back in the parent: the round-off floor, each method's checks, the planned list (what
the pytest plugin makes items of before anything runs), and a method's verdict."""

from __future__ import annotations

from ..metrics import ORDER_FLOOR
from ..results import Check, MethodResult
from ..runners import RUNNERS
from ..scenario import Scenario
from ..trajectory import step_label

__all__ = ["study_floor", "study_checks", "planned_checks", "verdict", "adaptive_note"]


def study_floor(results) -> float:
    """The error below which a study does not measure orders: the larger of :data:`ORDER_FLOOR` and 10x
    the smallest error any method reached (which bounds the reference's own error from above)."""
    errs = [r.attitude_error for res in results for r in res["runs"] if r.attitude_error]
    return max(ORDER_FLOOR, 10 * min(errs)) if errs else ORDER_FLOOR


def verdict(method: str, checks) -> str:
    """``pass`` | ``fail`` | ``expected`` | ``info`` (see :mod:`xcheck.results`)."""
    if any(c.kind == "reference" and not c.passed for c in checks):
        return "fail"  # nothing could be measured
    related = [c for c in checks if c.method == method]
    if not related:
        return "info"
    if any(c.kind == "expected-failure" for c in related):
        return "expected" if all(c.passed for c in related) else "fail"
    return "pass" if all(c.passed for c in related) else "fail"


def method_checks(m: MethodResult, cfg, torque_free, quick=False) -> list[Check]:
    """The regular checks of one method.

    A run that stops (singular, non-finite) fails the method only at its finest step: at coarse steps
    a method may legitimately be unstable, and the report shows those runs with their messages."""
    out = []
    expected = m.expected_order
    runs = sorted(m.runs, key=lambda r: r.setting)
    if runs and not runs[0].ok:
        out.append(Check("runs", False, m.name, note=runs[0].message or runs[0].status))
    finest = m.finest
    if expected is not None and finest is not None:
        order = m.observed_order
        if order is None:
            worst = max(r.attitude_error for r in runs if r.attitude_error is not None)
            out.append(Check("order", worst <= cfg["final_error"], m.name, None, expected,
                             f"no asymptotic range ({m.order_note}); every step within {worst:.2g} rad"))
        else:
            passed = expected - cfg["order_tolerance"] <= order <= expected + cfg["order_excess"]
            note = m.order_note
            if passed and order > expected + cfg["order_tolerance"]:
                note += "; faster than its order here: pre-asymptotic (the next error term still dominates)"
            out.append(Check("order", passed, m.name, order, expected, note))
        if expected >= 4 and not quick:
            out.append(Check("final-error", finest.attitude_error <= cfg["final_error"], m.name,
                             finest.attitude_error, cfg["final_error"], f"at dt = {finest.dt:g} s"))
    if torque_free and finest is not None and expected is not None and expected >= 4 and not quick:
        drift = max(finest.energy_drift, finest.momentum_drift)
        out.append(Check("invariants", drift <= cfg["invariant_tolerance"], m.name, drift, cfg["invariant_tolerance"],
                         f"energy and momentum drift at dt = {finest.dt:g} s"))
    return out


def planned_checks(scenario: Scenario, methods, quick: bool = False) -> list[tuple[str, str]]:
    """``(method, kind)`` of every check a study of ``methods`` makes, known before it runs (what the pytest
    plugin turns into test items): per method ``runs`` (its finest run completed), ``order`` (with an expected
    order), ``final-error`` and, torque free, ``invariants`` (order >= 4, full studies), ``agreement`` (an
    engine's RK4, when the study has one of our fourth-order methods); ``expected-failure`` instead of all of
    them for a method the scenario expects to fail. Kept beside :func:`_checks`, which makes them."""
    cfg = scenario.checks
    torque_free = scenario.torque is None
    ours4 = any(RUNNERS[m].engine == "xcheck" and RUNNERS[m].expected_order == 4 and m not in cfg["expected_to_fail"]
                for m in methods)
    out = []
    for m in methods:
        runner = RUNNERS[m]
        if m in cfg["expected_to_fail"]:
            out.append((m, "expected-failure"))
            continue
        out.append((m, "runs"))
        order = runner.order_for(scenario.torque)[0]
        if order is not None:
            out.append((m, "order"))
            if order >= 4 and not quick:
                out.append((m, "final-error"))
                if torque_free:
                    out.append((m, "invariants"))
        if runner.agreement and ours4 and runner.order_for(scenario.torque)[1] is None:
            out.append((m, "agreement"))
    return out


def adaptive_note(runs, fit) -> str:
    """An adaptive method's order note: how its error goes with the tolerance (the slope fitted over ``rtol``)."""
    if not runs:
        return ""
    if fit.order is None:
        return f"adaptive, at its own tolerances: {fit.note}"
    fitted = fit.note.replace("dt = ", "rtol = ").replace(" s", "")
    return (f"adaptive, at its own tolerances (output every {step_label(runs[0].dt)} s): the error goes as "
            f"rtol^{fit.order:.2f} ({fitted})")


def study_checks(scenario, methods, cfg, quick=False) -> list[Check]:
    torque_free = scenario.torque is None
    checks = []
    for m in methods.values():
        regular = method_checks(m, cfg, torque_free, quick)
        if m.name in cfg["expected_to_fail"]:
            failing = [c for c in regular if not c.passed]
            note = "; ".join(f"{c.name} fails" + (f" ({c.note})" if c.note else "") for c in failing)
            checks.append(Check("expected-failure", bool(failing), m.name,
                                note=note or "expected to fail, but every check passed"))
        else:
            checks += regular
    # every engine's RK4 against our best fourth-order method, at their finest steps
    ours = [m for m in methods.values() if m.engine == "xcheck" and m.expected_order == 4
            and m.name not in cfg["expected_to_fail"] and m.finest is not None]
    if ours:
        best = min(ours, key=lambda m: m.finest.attitude_error)
        for m in methods.values():
            runner = RUNNERS[m.name]
            if not runner.agreement or m.finest is None or runner.order_for(scenario.torque)[1] is not None:
                continue  # an engine's RK4 whose input is held over a step is not the same method as ours
            worst = max(m.finest.attitude_error, best.finest.attitude_error)
            checks.append(Check("agreement", worst <= cfg["agreement"], m.name, worst, cfg["agreement"],
                                f"{m.name} {m.finest.attitude_error:.3g} rad and {best.name} "
                                f"{best.finest.attitude_error:.3g} rad against the {scenario.reference} reference at "
                                "their finest steps"))
    return checks
