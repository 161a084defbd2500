"""The answer at the user's own step (issue 59): what a MuJoCo user asks first — at my time step, over my run, how far
off is each integrator? — read from the study's runs at :attr:`~xcheck.scenario.Scenario.your_step` (the model's
``<option timestep>``, MuJoCo's default 0.002 s where it sets none), nothing run again.

Per method, the **largest attitude error over the run** [rad] (the geodesic angle between its attitude and the
reference's, at any of its steps) against the scenario's ``[checks] tolerance`` (1e-6 rad unless it says; ``within``
means at most). A method that did not run at that step says why (an adaptive method takes its own steps; an engine's
step budget, or a run that failed, says so). The JSON is :func:`your_step_answer`'s, the ``your_step`` key of a
study's results (schema ``xcheck.convergence/3``); :func:`answer_line` is the first line a person reads."""

from __future__ import annotations

from ..defaults import DEFAULT_CHECKS
from ..invariants import RUN_KEYS
from ..runners import RUNNERS
from ..trajectory import same_step, step_label
from .statements import motion_of, short_law

__all__ = ["your_step_answer", "answer_line", "drift_words"]


def your_step_answer(scenario, steps, methods: dict, over_budget: dict) -> dict | None:
    """The answer at the user's step (see the module docstring), or None where the scenario knows no step of the
    user's. ``steps``: the study's; ``methods``: name -> :class:`~xcheck.results.MethodResult`; ``over_budget``:
    name -> (steps left out, why)."""
    dt = scenario.your_step
    if dt is None:
        return None
    tolerance = float(scenario.checks.get("tolerance", DEFAULT_CHECKS["tolerance"]))
    out = {"dt": dt, "source": scenario.your_step_why, "duration": scenario.duration, "tolerance": tolerance,
           "integrator": scenario.your_integrator, "studied": any(same_step(float(s), dt) for s in steps),
           "methods": {}, "not_run": {}}
    if not out["studied"]:
        out["why"] = (f"the scenario writes its steps ({', '.join(step_label(s) for s in steps)} s) and yours is not "
                      "among them: leave [study] steps out, or add it")
        return out
    for name, m in methods.items():
        if RUNNERS[name].adaptive:
            out["not_run"][name] = "adaptive: it chooses its own steps (see its tolerances)"
            continue
        run = next((r for r in m.runs if same_step(r.dt, dt)), None)
        if run is None:
            left, why = over_budget.get(name, ((), ""))
            out["not_run"][name] = why.split(";")[0] if any(same_step(s, dt) for s in left) else "not run at this step"
        elif not run.ok or run.max_attitude_error is None:
            out["not_run"][name] = run.message or run.status
        else:
            out["methods"][name] = {"error": run.max_attitude_error, "within": run.max_attitude_error <= tolerance,
                                    **{key: getattr(run, key) for key in RUN_KEYS},  # its invariants, signed
                                    **motion_of(run)}  # a tumbler's flips, a top's cone (xcheck.motion)
    return out


def drift_words(entry: dict) -> str | None:
    """Which way a method's run drifts, in words: ``gains energy (+4.0e-02) and |L| (+2.0e-02) ∝ t``, ``keeps
    energy (-6.0e-15) and |L| (-3.0e-15) to round-off``, ``damps energy (-3.8e-02) ∝ t, keeps |L| (...) to
    round-off``; None where neither is kept."""
    groups = {}  # (verb, tail) -> ["energy (+4.0e-02)", ...], in order
    for key, law_key, what in (("energy_change", "energy_law", "energy"), ("momentum_change", "momentum_law", "|L|")):
        change, law = entry.get(key), entry.get(law_key) or ""
        if change is None:
            continue
        if law == "round-off":
            verb, tail = "keeps", "to round-off"
        elif law == "bounded oscillation":
            verb, tail = "keeps", "within a bounded oscillation"
        else:
            verb, tail = "gains" if change > 0 else "damps", short_law(law)
        groups.setdefault((verb, tail), []).append(f"{what} ({change:+.1e})")
    return ", ".join(f"{verb} {' and '.join(items)}" + (f" {tail}" if tail else "")
                     for (verb, tail), items in groups.items()) or None


def _e(x: float) -> str:
    return f"{x:.2g}"


def answer_line(answer: dict | None) -> str | None:
    """The first line a person reads: the model's own integrator's error at their step over the run (else MuJoCo's
    first method's, else the first method's), with the tolerance's verdict, and the best of the rest; None without a
    step of the user's."""
    if answer is None:
        return None
    head = (f"at your Δt = {step_label(answer['dt'])} s ({answer['source']}) over {answer['duration']:g} s, "
            f"largest attitude error over the run")
    if not answer["studied"]:
        return f"{head}: not studied — {answer['why']}"
    tol = answer["tolerance"]
    own = f"mujoco-{answer['integrator']}" if answer["integrator"] else None
    ran = answer["methods"]
    parts = []
    first = own if own in ran or own in answer["not_run"] else next(iter(ran), None)
    if first in ran:
        r = ran[first]
        drift = drift_words(r)
        parts.append(f"{first} {_e(r['error'])} rad (tolerance {tol:g}: {'within' if r['within'] else 'not within'})"
                     + (f", {drift}" if drift else ""))
    elif first is not None:
        parts.append(f"{first} not run at it ({answer['not_run'][first]})")
    within = [n for n, r in ran.items() if r["within"]]
    others = {n: r for n, r in ran.items() if n != first}
    if others:
        best = min(others, key=lambda n: others[n]["error"])
        parts.append(f"{len(within)} of {len(ran)} methods within, the best {best} {_e(others[best]['error'])} rad")
    if not parts:
        parts.append("no method ran at it")
    fixed = [n for n, why in answer["not_run"].items() if n != first and not why.startswith("adaptive")]
    if fixed:
        parts.append(f"{len(fixed)} not run at it ({', '.join(fixed[:3])}{', …' if len(fixed) > 3 else ''})")
    return f"{head}: " + "; ".join(parts)
