"""Issue 23: timings that mean something, adaptive methods studied over their own tolerances, work counted
deterministically, and a first screen that never recommends a demonstration.

Truths: a fake clock for the repeat rule; the exact torque-free solution for the adaptive ladder (a tighter
tolerance must give a smaller error); the classical RK4's four stages for the evaluation counts; made-up study
results with known costs for the recommendation rule."""

import os
import subprocess
import sys

import numpy as np
import pytest

from xcheck import study
from xcheck.history.store import finest_error, report_metrics
from xcheck.integrators import METHODS, integrate
from xcheck.metrics import StepWithin
from xcheck.report.render import recommendation, scenario_summary
from xcheck.results import MethodResult, Run
from xcheck.runners import RUNNERS
from xcheck.scenario import ScenarioError, load_scenario, resolve_scenario
from xcheck.study import context, measure


# ------------------------------------------------------------------------------------------------------
# the repeat rule
# ------------------------------------------------------------------------------------------------------
class _Clock:
    """time.perf_counter for measure.timed_run: every run lasts ``run`` seconds (and the first ``first``)."""

    def __init__(self, run, first=None):
        self.now, self.run, self.first, self.calls = 0.0, run, first, 0

    def __call__(self):
        return self.now

    def advance(self):
        self.calls += 1
        self.now += self.first if (self.calls == 1 and self.first is not None) else self.run


class _Runner:
    def __init__(self, clock, ok=True):
        self.clock, self.ok, self.runs = clock, ok, 0

    def run(self, ctx, dt, rtol=None):
        self.runs += 1
        self.clock.advance()
        return type("T", (), {"ok": self.ok})()

    run_at = run


@pytest.mark.parametrize("seconds, first, repeats, best", [
    (0.0002, None, 5, 0.0002),  # short: the run limit (5) comes first
    (0.0008, None, 3, 0.0008),  # 0.8 + 0.8 = 1.6 ms < 2 ms, the third crosses the budget
    (0.004, 0.015, 1, 0.015),   # a first run over the budget is not repeated
    (0.0004, 0.0015, 3, 0.0004),  # a slow first run (loading) is replaced by the best of the repeats
    (0.05, None, 1, 0.05),      # long: once
])
def test_short_runs_are_repeated_within_a_budget_and_the_best_kept(monkeypatch, seconds, first, repeats, best):
    clock = _Clock(seconds, first)
    monkeypatch.setattr(measure.time, "perf_counter", clock)
    runner = _Runner(clock)
    _, wall, n = measure.timed_run(runner, None, 0.1)
    assert (n, runner.runs) == (repeats, repeats) and wall == pytest.approx(best)


def test_a_run_that_took_longer_than_one_with_more_work_is_timed_again(monkeypatch):
    """Truth: a fake clock. The coarse run met some noise (9 ms against 4 ms for twice the work); it is re-run
    (every run now takes 2 ms) until it is no slower, and keeps its best."""
    from types import SimpleNamespace

    clock = _Clock(0.002)
    monkeypatch.setattr(measure.time, "perf_counter", clock)
    runner = _Runner(clock)
    runs = [Run(0.2, wall_time=0.009, evaluations=40, repeats=1), Run(0.1, wall_time=0.004, evaluations=80, repeats=1)]
    measure._retime_outliers(runner, SimpleNamespace(duration=1.0), runs)
    assert runner.runs == 1 and runs[0].wall_time == pytest.approx(0.002) and runs[0].repeats == 2
    assert runs[0].steps_per_second == pytest.approx(5 / 0.002)
    # no more work (the same evaluations): nothing to re-time
    runs = [Run(0.2, wall_time=0.009, evaluations=40), Run(0.1, wall_time=0.004, evaluations=40)]
    measure._retime_outliers(runner, SimpleNamespace(duration=1.0), runs)
    assert runner.runs == 1 and runs[0].wall_time == 0.009


def test_a_failed_run_is_not_repeated(monkeypatch):
    clock = _Clock(0.001)
    monkeypatch.setattr(measure.time, "perf_counter", clock)
    runner = _Runner(clock, ok=False)
    assert measure.timed_run(runner, None, 0.1)[2] == 1 and runner.runs == 1


# ------------------------------------------------------------------------------------------------------
# work as evaluations
# ------------------------------------------------------------------------------------------------------
def test_evaluations_are_four_a_step_for_every_rk4_and_one_for_mujocos_euler():
    """(And two for the variational integrator: the torque at the step's start and end; one a Strang step for the
    splittings, the end's torque being the next start's.)"""
    sc = resolve_scenario("tumbler-intermediate-axis")
    ctx = context.run_context(sc)
    n = round(sc.duration / 0.125)
    for name, m in METHODS.items():
        if m.kernel is not None:
            per_step = {"lie-lgvi": 2, "split-strang": 1, "split-yoshida4": 3}.get(name, 4)
            assert RUNNERS[name].run(ctx, 0.125).extras["evaluations"] == per_step * n, name
    assert RUNNERS["mujoco-rk4"].run(ctx, 0.125).extras["evaluations"] == 4 * n
    assert RUNNERS["mujoco-euler"].run(ctx, 0.125).extras["evaluations"] == n
    scipy = RUNNERS["scipy-rk45"].run(ctx, 0.125)
    assert scipy.extras["evaluations"] > 0 and scipy.extras["tolerances"] == (1e-3, 1e-6)


# ------------------------------------------------------------------------------------------------------
# adaptive methods over their own tolerances
# ------------------------------------------------------------------------------------------------------
def test_an_adaptive_method_is_studied_over_its_tolerances_against_the_exact_solution():
    sc = resolve_scenario("tumbler-intermediate-axis")
    st = study.run_study(sc, methods=["scipy-rk45", "lie-rkmk4"], quick=True, workers=1)
    m = st.methods["scipy-rk45"]
    assert m.adaptive and not st.methods["lie-rkmk4"].adaptive
    assert [r.rtol for r in m.runs] == list(sc.quick_tolerances) and {r.dt for r in m.runs} == {sc.adaptive_step}
    errors = [r.max_attitude_error for r in m.runs]
    evaluations = [r.evaluations for r in m.runs]
    assert all(a > 10 * b for a, b in zip(errors, errors[1:]))  # two decades of tolerance: over a decade of error
    assert evaluations == sorted(evaluations) and len(set(evaluations)) == len(evaluations)
    assert m.finest.rtol == min(sc.quick_tolerances) and m.observed_order is None
    assert "rtol^" in m.order_note  # its tolerance proportionality, not an order in a step
    # the loosest tolerance within 1e-6 rad lies between the two rungs that bracket 1e-6
    w = m.within["1e-06"]
    assert w.dt is None and w.rtol is not None and w.reached
    tight = [r.rtol for r in m.runs if r.max_attitude_error <= 1e-6]
    loose = [r.rtol for r in m.runs if r.max_attitude_error > 1e-6]
    assert min(loose) > w.rtol >= max(tight)
    doc = st.data["methods"]["scipy-rk45"]
    assert all("rtol" in r for r in doc["runs"]) and all("rtol" not in r for r in st.data["methods"]["lie-rkmk4"]["runs"])
    assert doc["loosest_tolerance_within"]["1e-06"] == w.rtol
    # no direct comparison at a step it does not vary, and the history keys each rung apart
    assert not any(c["a"] == "scipy-rk45" for c in st.comparisons)
    rows = [r for r in report_metrics({"scenarios": [st.data]}) if r[1].startswith("scipy-rk45 ")]
    assert {r[1] for r in rows} == {f"scipy-rk45 rtol={t:.0e}" for t in sc.quick_tolerances}
    assert finest_error(doc) == m.finest.attitude_error


def test_the_default_rung_of_scipy_rk45_is_seed_001s_run():
    """rtol 1e-3 is solve_ivp's default: the same numbers as a run without a tolerance."""
    sc = resolve_scenario("gyroscope-nonsingular")
    ctx = context.run_context(sc)
    a, b = RUNNERS["scipy-rk45"].run(ctx, 0.5), RUNNERS["scipy-rk45"].run(ctx, 0.5, 1e-3)
    assert np.array_equal(a.q, b.q) and a.extras["evaluations"] == b.extras["evaluations"]


def test_a_tolerance_is_refused_by_a_fixed_step_method():
    sc = resolve_scenario("gyroscope-nonsingular")
    with pytest.raises(ValueError, match=r"rtol: lie-rkmk4 is a fixed-step method"):
        integrate("lie-rkmk4", [1, 2, 2], sc.q0, sc.omega0, dt=0.5, duration=1.0, rtol=1e-6)
    with pytest.raises(ValueError, match=r"rtol: expected a relative tolerance in \(0, 1\)"):
        integrate("scipy-rk45", [1, 2, 2], sc.q0, sc.omega0, dt=0.5, duration=1.0, rtol=2.0)


@pytest.mark.parametrize("line, message", [
    ("tolerances = [1e-3, 1e-3]", r"\[study\] tolerances: a tolerance is given twice"),
    ("quick_tolerances = [0.5]", r"\[study\] quick_tolerances: expected relative tolerances between 1e-14 and 0.1"),
    ("tolerances = []", r"\[study\] tolerances: expected a non-empty list"),
    ("adaptive_step = 20.0", r"\[study\] adaptive_step: the step 20 s is longer than the duration"),
])
def test_an_adaptive_ladder_that_cannot_run_is_refused_by_name(tmp_path, line, message):
    gyro = resolve_scenario("gyroscope-nonsingular")
    text = gyro.path.read_text().replace('"../gyroscope.xml"', f'"{gyro.model.as_posix()}"')
    path = tmp_path / "s.toml"
    path.write_text(text.replace("[study]", f"[study]\n{line}"))
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)


# ------------------------------------------------------------------------------------------------------
# what the first screen recommends
# ------------------------------------------------------------------------------------------------------
def _method(name, wall, engine="xcheck", verdict="pass"):
    m = MethodResult(name, engine, RUNNERS[name].expected_order if name in RUNNERS else 4,  # Basilisk's may be absent
                     runs=[Run(0.01, attitude_error=1e-7)], verdict=verdict)
    m.within = {"1e-06": StepWithin(0.01, wall, "interpolated")}
    return m


def _study(methods):
    sc = resolve_scenario("gyroscope-nonsingular")
    return study.StudyResult(scenario=sc, steps=[0.01], methods={m.name: m for m in methods}, checks=[],
                             order_floor=1e-12)


def test_a_demonstration_is_never_recommended_and_the_first_screen_says_why():
    """Truth: lie-thesis-172 (seed 004's misprint, kept to show it) is the cheapest by construction."""
    assert RUNNERS["lie-thesis-172"].demonstration and not RUNNERS["lie-rkmk4"].demonstration
    st = _study([_method("lie-thesis-172", 1e-4), _method("lie-rkmk4", 3e-4), _method("formulation-2", 5e-4),
                 _method("mujoco-rk4", 9e-3, engine="mujoco")])
    text = " ".join(recommendation(st))
    assert text.startswith("Cheapest to 1e-6 rad over the run: lie-rkmk4 at Δt ≈ 0.01 s (0.3 ms a run).")
    assert "(lie-thesis-172 would take 0.1 ms but is not advised: it is seed 004's algorithm 172 as printed" in text
    assert "Cheapest in mujoco: mujoco-rk4" in text and "30× the time" in text
    # every other engine gets its own cheapest, MuJoCo's first, whichever is cheaper
    st.methods["basilisk-rk4"] = _method("basilisk-rk4", 1e-3, engine="basilisk")
    text = " ".join(recommendation(st))
    assert text.index("Cheapest in mujoco: mujoco-rk4") < text.index("Cheapest in basilisk: basilisk-rk4")
    assert "lie-thesis-172" not in scenario_summary(_study([_method("lie-rkmk4", 3e-4),
                                                            _method("lie-thesis-172", 9e-4)]))


def test_only_demonstrations_within_reach_means_no_recommendation():
    assert recommendation(_study([_method("lie-thesis-172", 1e-4)])) == [
        "No method stays within 1e-6 rad at the tested steps."]


def test_an_adaptive_method_is_recommended_at_its_tolerance():
    m = _method("scipy-rk45", 1e-4)
    m.within = {"1e-06": StepWithin(None, 1e-4, "interpolated", rtol=3.2e-7)}
    text = recommendation(_study([m, _method("lie-rkmk4", 3e-4)]))[0]
    assert text == "Cheapest to 1e-6 rad over the run: scipy-rk45 at rtol ≈ 3.2e-07 (0.1 ms a run)."


# ------------------------------------------------------------------------------------------------------
# an installed engine left out
# ------------------------------------------------------------------------------------------------------
def test_xcheck_without_leaves_an_installed_engine_out():
    pytest.importorskip("Basilisk", reason="Basilisk is not installed (pip install 'xcheck[basilisk]')")
    code = "from xcheck.runners import RUNNERS; print(sorted(n for n in RUNNERS if n.startswith('basilisk')))"
    base = {k: v for k, v in os.environ.items() if k != "XCHECK_WITHOUT"}
    run = lambda env: subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,  # noqa: E731
                                     env={**base, **env}, check=True).stdout.strip()
    assert run({}) == str(["basilisk-rk4", "basilisk-rkf45", "basilisk-rkf78"])
    assert run({"XCHECK_WITHOUT": "basilisk"}) == "[]"


@pytest.mark.parametrize("rate, duration, step", [
    (0.0, 10.0, 0.5),       # at rest: the study's coarsest step
    (4.0, 10.0, 0.5),       # 2 rad in 1/2 s: still 1/2 s
    (15.71, 10.0, 0.125),   # seed 001's gyroscope: 7.9 rad in 1/2 s, 1.96 in 1/8 s
    (4.0, 0.3, 0.3),        # a duration shorter than 1/2 s, 1.2 rad in it
    (1e6, 10.0, 2.0**-10),  # as fast as anything: 1/1024 s at least
])
def test_the_default_adaptive_step_turns_the_body_by_at_most_two_radians(rate, duration, step):
    from xcheck.scenario import ADAPTIVE_TURN, default_adaptive_step

    got = default_adaptive_step(np.array([0.0, 0.6, 0.8]) * rate, duration)
    assert got == step and (rate * got <= ADAPTIVE_TURN or got == 2.0**-10)


def test_a_scenarios_own_adaptive_step_is_kept(tmp_path):
    text = (resolve_scenario("gyroscope-nonsingular").path.read_text().replace('model = "../gyroscope.xml"',
            f'model = "{resolve_scenario("gyroscope-nonsingular").model}"') + "adaptive_step = 0.5\n")
    path = tmp_path / "own.toml"
    path.write_text(text)
    assert resolve_scenario(str(path)).adaptive_step == 0.5
    assert resolve_scenario("gyroscope-nonsingular").adaptive_step == 0.125
