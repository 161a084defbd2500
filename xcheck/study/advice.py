"""What to use instead (issue 62): per engine, the cheapest of its integrators and the largest step that keeps the
user's tolerance over the run, read from the study's own runs (its work–precision data), nothing run again.

**The step** advised for a method is the largest step it was run at whose largest attitude error over the run [rad]
was within the tolerance, at that step and at every finer step it was run at (one good step between bad ones is
luck, not a step to rely on). Never a step between two studied ones: an error there would be an interpolation,
not a measurement. **The cheapest** of an engine's methods is the one whose run at its advised step took the least
wall time (the best of the study's timed runs; this machine's). The tolerance is the scenario's ``[checks]
tolerance`` (1e-6 rad unless it says), over the scenario's duration.

The line is one a user can copy: MuJoCo's the MJCF ``<option integrator="RK4" timestep="0.0009765625"/>`` (the
step written exactly: the study's steps are binary fractions), ours an ``xcheck run`` command, another engine's its
method and step. Where no studied step of an engine keeps the tolerance, the line says so and gives its best: the
least error any of its methods reached, and where. The JSON is :func:`advice`'s, the ``advice`` key of a study's
results (schema ``xcheck.convergence/3``)."""

from __future__ import annotations

from pathlib import Path

from ..defaults import DEFAULT_CHECKS
from ..engines.built import ENGINE_NAMES
from ..paths import BUNDLED_MODELS
from ..runners import RUNNERS
from ..trajectory import step_label

__all__ = ["advice", "advised_run", "advice_parts", "advice_lines", "MJCF_INTEGRATORS", "ENGINE_NAMES"]

#: MuJoCo's methods by the name of the integrator in MJCF's ``<option integrator=...>``.
MJCF_INTEGRATORS = {"mujoco-euler": "Euler", "mujoco-rk4": "RK4", "mujoco-implicit": "implicit",
                    "mujoco-implicitfast": "implicitfast"}


def advised_run(m, tolerance: float):
    """The run of method ``m`` (a :class:`~xcheck.results.MethodResult`) at its largest step that keeps
    ``tolerance`` [rad] there and at every finer step it ran (see the module), or None."""
    best = None
    for run in sorted(m.runs, key=lambda r: r.dt):  # fine to coarse
        if not run.ok or run.max_attitude_error is None or run.max_attitude_error > tolerance:
            break
        best = run
    return best


def advice(scenario, methods: dict) -> list[dict]:
    """Per engine (in the order of the study's methods), the advice of the module: ``{"engine", "tolerance",
    "duration", "method", "dt", "error", "wall_time", "coarsest"}`` (``coarsest``: the step is the coarsest it
    ran), or where none keeps the tolerance ``{"engine", "tolerance",
    "duration", "method": None, "best": {"method", "dt", "error"} or None}``. Adaptive methods are left out (they
    choose their own steps)."""
    tolerance = float(scenario.checks.get("tolerance", DEFAULT_CHECKS["tolerance"]))
    by_engine: dict = {}
    for name, m in methods.items():
        if not RUNNERS[name].adaptive:
            by_engine.setdefault(RUNNERS[name].engine, []).append(m)
    out = []
    for engine, ms in by_engine.items():
        base = {"engine": engine, "tolerance": tolerance, "duration": scenario.duration}
        kept = [(m, run) for m in ms if (run := advised_run(m, tolerance)) is not None]
        if kept:
            m, run = min(kept, key=lambda mr: (mr[1].wall_time is None, mr[1].wall_time or 0.0, -mr[1].dt))
            out.append({**base, "method": m.name, "dt": run.dt, "error": run.max_attitude_error,
                        "wall_time": run.wall_time, "coarsest": run.dt >= max(r.dt for r in m.runs)})
            continue
        done = [(m.name, r) for m in ms for r in m.runs if r.ok and r.max_attitude_error is not None]
        name, run = min(done, key=lambda nr: nr[1].max_attitude_error) if done else (None, None)
        out.append({**base, "method": None, "best": None if run is None else
                    {"method": name, "dt": run.dt, "error": run.max_attitude_error}})
    return out


def _use(a: dict, scenario) -> str:
    """What to write for the advised method and step: MJCF for MuJoCo, a command for ours, else the method."""
    dt = repr(float(a["dt"]))
    if a["method"] in MJCF_INTEGRATORS:
        return f'<option integrator="{MJCF_INTEGRATORS[a["method"]]}" timestep="{dt}"/>'
    if a["engine"] == "xcheck":
        path = scenario.path
        bundled = path is not None and Path(path).resolve().parent == (BUNDLED_MODELS / "scenarios").resolve()
        return f"xcheck run {scenario.name if bundled or path is None else path} --method {a['method']} --dt {dt}"
    return f"{a['method']} at Δt = {dt} s"


def advice_parts(st) -> list[tuple[str, str | None, str]]:
    """The study's advice, per engine, as ``(who, what to write or None, the rest)``: ``("MuJoCo, for 1e-06 rad
    over 10 s", '<option integrator="RK4" timestep="0.0009765625"/>', "2.2e-13 rad there, 5.1 ms a run here")``, or
    ``(who, None, "no studied step keeps it; ...")``."""
    out = []
    for a in st.advice or []:
        who = f"{ENGINE_NAMES.get(a['engine'], a['engine'])}, for {a['tolerance']:g} rad over {a['duration']:g} s"
        if a["method"] is not None:
            cost = "" if a["wall_time"] is None else f", {a['wall_time'] * 1e3:.2g} ms a run here"
            coarsest = "; the coarsest step studied: a larger one may keep it too" if a.get("coarsest") else ""
            out.append((who, _use(a, st.scenario), f"{a['error']:.1e} rad there{cost}{coarsest}"))
        elif a["best"] is None:
            out.append((who, None, "no studied step keeps it (none of its runs completed)"))
        else:
            b = a["best"]
            out.append((who, None, f"no studied step keeps it; its least error is {b['error']:.1e} rad "
                                   f"({b['method']} at {step_label(b['dt'])} s)"))
    return out


def advice_lines(st) -> list[str]:
    """:func:`advice_parts` as the terminal's lines."""
    return [f"{who}: {use}  ({rest})" if use else f"{who}: {rest}" for who, use, rest in advice_parts(st)]
