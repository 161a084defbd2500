"""The checks of a study, back in the parent: the round-off floor, each method's checks, the planned list (what
the pytest plugin makes items of before anything runs), and a method's verdict."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..metrics import ORDER_FLOOR
from ..results import Check, MethodResult
from ..runners import RUNNERS
from ..scenario import Scenario
from ..trajectory import step_label

__all__ = ["study_floor", "study_checks", "planned_checks", "verdict", "adaptive_note", "RULES", "Rule", "Plan"]


def study_floor(results) -> float:
    """The error below which a study does not measure orders: the larger of :data:`ORDER_FLOOR` and 10x
    the smallest error any method reached (which bounds the reference's own error from above)."""
    errs = [r.attitude_error for res in results for r in res.runs if r.attitude_error]
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


@dataclass(frozen=True)
class Plan:
    """What is known of a method before its study runs, which decides its checks: its expected order under the
    scenario's torque (None: none is claimed), whether the scenario is torque free, a quick study, and whether
    it is an engine's RK4 compared with our best fourth-order method (``agreement``)."""

    order: int | None
    torque_free: bool
    quick: bool
    agreement: bool


@dataclass(frozen=True)
class Rule:
    """One kind of check: when a method has it (``applies``, read by the planner and the checker alike) and how it
    is made from the method's result (``make``: a :class:`Check`, or None where nothing fails: the ``runs``
    check is made only when the finest run failed). ``across``: made after every method's own checks (it
    compares methods)."""

    kind: str
    applies: Callable[[Plan], bool]
    make: Callable
    across: bool = False


def _runs(m: MethodResult, cfg, ctx) -> Check | None:
    """A run that stops (singular, non-finite) fails the method only at its finest step: at coarse steps a method
    may legitimately be unstable, and the report shows those runs with their messages."""
    runs = sorted(m.runs, key=lambda r: r.setting)
    return Check("runs", False, m.name, note=runs[0].message or runs[0].status) if runs and not runs[0].ok else None


def _order(m: MethodResult, cfg, ctx) -> Check | None:
    if m.finest is None:
        return None
    expected, order = m.expected_order, m.observed_order
    if order is None:
        worst = max(r.attitude_error for r in m.runs if r.attitude_error is not None)
        return Check("order", worst <= cfg["final_error"], m.name, None, expected,
                     f"no asymptotic range ({m.order_note}); every step within {worst:.2g} rad")
    passed = expected - cfg["order_tolerance"] <= order <= expected + cfg["order_excess"]
    note = m.order_note
    runner = RUNNERS.get(m.name)
    finding = runner.finding() if not passed and runner is not None and runner.finding else None
    if finding:  # a known finding of the engine's release: named, with the release to take
        note += f"; {finding}"
    if passed and order > expected + cfg["order_tolerance"]:
        note += "; faster than its order here: pre-asymptotic (the next error term still dominates)"
    return Check("order", passed, m.name, order, expected, note)


def _final_error(m: MethodResult, cfg, ctx) -> Check | None:
    f = m.finest
    return None if f is None else Check("final-error", f.attitude_error <= cfg["final_error"], m.name,
                                        f.attitude_error, cfg["final_error"], f"at dt = {f.dt:g} s")


def _invariants(m: MethodResult, cfg, ctx) -> Check | None:
    f = m.finest
    if f is None:
        return None
    drifts = {name: value for name, value in (("energy", f.energy_drift), ("momentum", f.momentum_drift),
                                              ("spin momentum", f.spin_drift)) if value is not None}
    if not drifts:
        return None
    drift = max(drifts.values())
    return Check("invariants", drift <= cfg["invariant_tolerance"], m.name, drift, cfg["invariant_tolerance"],
                 f"{' and '.join(drifts)} drift at dt = {f.dt:g} s")


def _agreement(m: MethodResult, cfg, ctx) -> Check | None:
    best = ctx["best"]
    if best is None or m.finest is None:
        return None
    worst = max(m.finest.attitude_error, best.finest.attitude_error)
    return Check("agreement", worst <= cfg["agreement"], m.name, worst, cfg["agreement"],
                 f"{m.name} {m.finest.attitude_error:.3g} rad and {best.name} {best.finest.attitude_error:.3g} rad "
                 f"against the {ctx['reference']} reference at their finest steps")


def _fourth_order(p: Plan) -> bool:
    return p.order is not None and p.order >= 4 and not p.quick


#: Every check a method can have, in the order a study lists them: the planner (:func:`planned_checks`, what the
#: pytest plugin makes items of) and the checker (:func:`study_checks`) both read this table.
RULES = (
    Rule("runs", lambda p: True, _runs),
    Rule("order", lambda p: p.order is not None, _order),
    Rule("final-error", _fourth_order, _final_error),
    Rule("invariants", lambda p: p.torque_free and _fourth_order(p), _invariants),
    # an engine's RK4 against our best fourth-order method, at their finest steps (one whose input is held over a
    # step is not the same method as ours)
    Rule("agreement", lambda p: p.agreement, _agreement, across=True),
)


def _plans(scenario: Scenario, methods, quick: bool) -> dict[str, Plan]:
    cfg = scenario.checks
    torque_free = scenario.torque is None
    ours4 = any(RUNNERS[m].engine == "xcheck" and RUNNERS[m].expected_order == 4 and m not in cfg["expected_to_fail"]
                for m in methods)
    out = {}
    for m in methods:
        runner = RUNNERS[m]
        order, held = runner.order_for(scenario.torque, scenario.model)
        out[m] = Plan(order=order, torque_free=torque_free, quick=quick,
                      agreement=runner.agreement and ours4 and held is None)
    return out


def planned_checks(scenario: Scenario, methods, quick: bool = False) -> list[tuple[str, str]]:
    """``(method, kind)`` of every check a study of ``methods`` makes, known before it runs (what the pytest
    plugin turns into test items), from :data:`RULES`; ``expected-failure`` instead of all of them for a method
    the scenario expects to fail."""
    expected_to_fail = scenario.checks["expected_to_fail"]
    plans = _plans(scenario, methods, quick)
    out = []
    for m in methods:
        if m in expected_to_fail:
            out.append((m, "expected-failure"))
            continue
        out += [(m, rule.kind) for rule in RULES if rule.applies(plans[m])]
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


def study_checks(scenario: Scenario, methods: dict, cfg, quick: bool = False) -> list[Check]:
    """Every check of a study from its methods' results (:class:`MethodResult` by name), by :data:`RULES`: each
    method's own checks, then those across methods; a method the scenario expects to fail has one
    ``expected-failure`` check, passed when one of its own checks failed."""
    plans = _plans(scenario, list(methods), quick)
    expected_to_fail = cfg["expected_to_fail"]
    ours = [m for m in methods.values() if m.engine == "xcheck" and m.expected_order == 4
            and m.name not in expected_to_fail and m.finest is not None]
    ctx = {"best": min(ours, key=lambda m: m.finest.attitude_error) if ours else None,
           "reference": scenario.reference}

    def made(m, across: bool):
        return [c for rule in RULES if rule.across == across and rule.applies(plans[m.name])
                for c in [rule.make(m, cfg, ctx)] if c is not None]

    checks = []
    for m in methods.values():
        regular = made(m, False)
        if m.name in expected_to_fail:
            failing = [c for c in regular if not c.passed]
            note = "; ".join(f"{c.name} fails" + (f" ({c.note})" if c.note else "") for c in failing)
            checks.append(Check("expected-failure", bool(failing), m.name,
                                note=note or "expected to fail, but every check passed"))
        else:
            checks += regular
    for m in methods.values():
        if m.name not in expected_to_fail:
            checks += made(m, True)
    return checks
