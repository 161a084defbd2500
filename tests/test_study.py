"""The study's judgement (xcheck.study.assemble) on made-up worker results with known answers: orders and
checks, the agreement check for every engine RK4 (runners with ``agreement``), expected failures, a reference
that could not be computed, and the JSON it makes (schema xcheck.convergence/3)."""

import dataclasses

import pytest

from xcheck.results import MethodRuns, Run
from xcheck.runners import RUNNERS
from xcheck.scenario import resolve_scenario
from xcheck.study import assemble, run_study

STEPS = [2.0**-k for k in range(3, 8)]


def runs(p, c=1e-2):
    """Runs whose final error is exactly c dt^p (an observed order of p)."""
    return [Run(dt, attitude_error=c * dt**p, max_attitude_error=c * dt**p, omega_error=0.0, max_omega_error=0.0,
                energy_change=1e-14, momentum_change=-1e-14, momentum_turn=1e-14, norm_drift=0.0, wall_time=0.01, steps_per_second=1e5)
            for dt in STEPS]


@pytest.fixture
def scenario():
    return resolve_scenario("tumbler-intermediate-axis")


def result(method, rs, **extra):
    return MethodRuns(method, rs, **extra)


def test_orders_and_checks(scenario):
    st = assemble(scenario, STEPS, [result("lie-rkmk4", runs(4)), result("lie-thesis-172", runs(2)),
                                    result("mujoco-euler", runs(2))], quick=True)
    m = st.methods
    assert m["lie-rkmk4"].observed_order == pytest.approx(4) and m["lie-rkmk4"].verdict == "pass"
    assert m["lie-thesis-172"].verdict == "pass"  # expected order 2
    assert m["mujoco-euler"].verdict == "pass"  # 2 <= 1 + order_excess: faster than its order is not a defect
    checks = {c.name: c for c in st.checks}
    assert checks["order:mujoco-euler"].note.endswith("pre-asymptotic (the next error term still dominates)")
    assert st.passed and "final-error:lie-rkmk4" not in checks  # quick: no final-error check


def test_a_lower_order_fails(scenario):
    st = assemble(scenario, STEPS, [result("formulation-2", runs(3))])
    c = {c.name: c for c in st.checks}["order:formulation-2"]
    assert not c.passed and c.value == pytest.approx(3) and c.limit == 4 and not st.passed
    assert st.methods["formulation-2"].verdict == "fail"


def test_agreement_runs_for_every_engine_rk4(scenario, monkeypatch):
    """Truth: |e_engine| and |e_ours| at the finest step; the check takes the larger of the two."""
    st = assemble(scenario, STEPS, [result("lie-rkmk4", runs(4, 1e-6)), result("mujoco-rk4", runs(4, 2e-6)),
                                    result("mujoco-euler", runs(1))])
    agreement = [c for c in st.checks if c.kind == "agreement"]
    assert [c.method for c in agreement] == ["mujoco-rk4"]
    assert agreement[0].value == pytest.approx(2e-6 * STEPS[-1] ** 4)
    # another engine's RK4 joins by its runner's flag alone
    monkeypatch.setitem(RUNNERS, "mujoco-euler", dataclasses.replace(RUNNERS["mujoco-euler"], agreement=True))
    st = assemble(scenario, STEPS, [result("lie-rkmk4", runs(4, 1e-6)), result("mujoco-euler", runs(1))])
    assert [c.name for c in st.checks if c.kind == "agreement"] == ["agreement:mujoco-euler"]


def test_expected_failure(scenario):
    sc = dataclasses.replace(scenario, checks={**scenario.checks, "expected_to_fail": ["euler-rk4"]})
    failing = assemble(sc, STEPS, [result("euler-rk4", runs(2))])
    assert failing.methods["euler-rk4"].verdict == "expected" and failing.passed
    passing = assemble(sc, STEPS, [result("euler-rk4", runs(4))])
    assert passing.methods["euler-rk4"].verdict == "fail" and not passing.passed
    assert passing.checks[0].note == "expected to fail, but every check passed"


def test_reference_failure_is_the_one_check(scenario):
    rs = [Run.failed(dt, "failed", "no reference: budget", 0.0) for dt in STEPS]
    st = assemble(scenario, STEPS, [result("lie-rkmk4", rs, reference_error="budget")])
    assert [c.name for c in st.checks] == ["reference"] and not st.passed
    assert st.methods["lie-rkmk4"].verdict == "fail" and st.methods["lie-rkmk4"].status == "failed"


def test_a_reference_that_fails_when_evaluated_fails_the_study(scenario, monkeypatch):
    """A reference that fails on a run's grid (after its guard passed, at the guard's own times) is the study's one
    "reference" check, not an internal error. Here the closed form refuses any grid of more than 20 times (the guard
    asks for 16)."""
    from xcheck import reference
    from xcheck.study import context

    exact = reference.exact_reference

    def refusing(inertia, q0, omega0, t, torque=None):
        if len(t) > 20:
            raise reference.ReferenceFailure("a closed form that gives up on long grids")
        return exact(inertia, q0, omega0, t, torque)

    monkeypatch.setattr(reference, "exact_reference", refusing)
    monkeypatch.setattr(context, "exact_reference", refusing)
    monkeypatch.setattr(context, "_CACHE", {})  # no reference of this scenario from an earlier test
    st = run_study(scenario, methods=["lie-rkmk4"], steps=[0.125, 0.0625], workers=1)
    assert [c.name for c in st.checks] == ["reference"] and not st.passed
    assert "a closed form that gives up on long grids" in st.checks[0].note


def test_json_keeps_the_schema(scenario):
    data = assemble(scenario, STEPS, [result("lie-rkmk4", runs(4))]).data
    assert data["schema"] == "xcheck.convergence/3" and data["scenario"] == "tumbler-intermediate-axis"
    assert set(data) >= {"description", "model", "duration", "reference", "torque", "initial", "quick", "steps",
                         "order_floor", "versions", "methods", "checks", "passed"}
    assert set(data["methods"]["lie-rkmk4"]) >= {"engine", "expected_order", "observed_order", "order_note",
                                                 "local_orders", "status", "runs", "verdict"}


def test_run_study_refuses_bad_steps(scenario):
    with pytest.raises(ValueError, match="steps: the step 50 s is longer than the duration"):
        run_study(scenario, methods=["lie-rkmk4"], steps=[50.0], workers=1)


# ------------------------------------------------------------------------------------------------
# what a tolerance costs, and engines against ours without a reference (issue 10)
# ------------------------------------------------------------------------------------------------
def test_step_within_in_the_json(scenario):
    """Truth: runs(4) has max error 1e-2 dt^4: within 1e-3 rad at every step (the coarsest, 1/8 s: "tested"),
    1e-6 rad up to dt = (1e-4)^(1/4) = 0.1 s and 1e-9 rad up to (1e-7)^(1/4) = 0.01778 s (interpolated)."""
    data = assemble(scenario, STEPS, [result("lie-rkmk4", runs(4))]).data
    m = data["methods"]["lie-rkmk4"]
    assert set(m["largest_step_within"]) == {"1e-03", "1e-06", "1e-09"}
    assert m["largest_step_within"]["1e-03"] == 0.125 and m["cost_within"]["1e-03"]["how"] == "tested"
    assert m["largest_step_within"]["1e-06"] == pytest.approx(0.1, rel=1e-12)
    assert m["largest_step_within"]["1e-09"] == pytest.approx(1e-7 ** 0.25, rel=1e-12)
    assert m["cost_within"]["1e-09"]["how"] == "interpolated" and m["cost_within"]["1e-09"]["wall_time"] == pytest.approx(0.01, rel=1e-12)
    assert all("wall_time" in r for r in m["runs"]) and data["comparisons"] == []


def test_comparison_partners(scenario):
    from xcheck.study import comparison_partner

    every = list(RUNNERS)
    assert comparison_partner(scenario, "mujoco-rk4", every) == "lie-rkmk4"  # same order, the reference method
    assert comparison_partner(scenario, "mujoco-euler", every) == "lie-rkmk4"  # no first-order method of ours
    assert comparison_partner(scenario, "mujoco-rk4", ["formulation-2", "mujoco-rk4"]) == "formulation-2"
    assert comparison_partner(scenario, "mujoco-rk4", ["lie-thesis-172", "mujoco-rk4"]) == "lie-thesis-172"
    assert comparison_partner(scenario, "lie-rkmk4", every) is None  # ours are compared with the reference
    assert comparison_partner(scenario, "mujoco-rk4", ["mujoco-rk4", "scipy-rk45"]) is None


def test_direct_comparison_is_the_trajectories_difference():
    """Truth: both trajectories run here, their largest attitude difference over the grid, bit for bit; and
    without a reference, MuJoCo's Euler differs from lie-rkmk4 by about its own error (within 1 %)."""
    import numpy as np

    from xcheck import rotations as rot
    from xcheck.study.context import run_context

    sc = resolve_scenario("gyroscope-nonsingular")
    steps = [1 / 64, 1 / 128]
    st = run_study(sc, methods=["lie-rkmk4", "mujoco-rk4", "mujoco-euler"], steps=steps, workers=1)
    got = {(c["a"], c["b"], c["dt"]): c["max_attitude_difference"] for c in st.data["comparisons"]}
    assert set(got) == {(a, "lie-rkmk4", dt) for a in ("mujoco-rk4", "mujoco-euler") for dt in steps}
    ctx = run_context(sc)
    for (a, b, dt), value in got.items():
        ta, tb = RUNNERS[a].run(ctx, dt), RUNNERS[b].run(ctx, dt)
        assert value == float(np.max(rot.attitude_error(ta.q, tb.q)))
    assert got[("mujoco-rk4", "lie-rkmk4", 1 / 128)] < 1e-12  # MuJoCo's RK4 on a free body is RKMK4 (measured)
    euler = st.methods["mujoco-euler"].runs[-1]
    assert got[("mujoco-euler", "lie-rkmk4", 1 / 128)] == pytest.approx(euler.max_attitude_error, rel=1e-2)


def test_a_comparison_left_to_the_assembling_process_is_the_same(monkeypatch):
    """A process without our compiled code loaded (a worker that drives Basilisk alone) leaves the direct
    comparisons to the process that assembles the study, sending the run's times and attitudes: the same
    numbers, bit for bit, as the comparisons made where the run was."""
    from xcheck.study import measure

    sc = resolve_scenario("gyroscope-nonsingular")
    steps = (1 / 64, 1 / 128)
    monkeypatch.setattr(measure, "compiled_code_loaded", lambda: True)
    here = measure.measure_method(sc, "mujoco-rk4", steps, "lie-rkmk4")
    monkeypatch.setattr(measure, "compiled_code_loaded", lambda: False)
    left = measure.measure_method(sc, "mujoco-rk4", steps, "lie-rkmk4")
    assert [sorted(c) for c in left.comparisons] == [["a", "b", "dt", "later"]] * 2
    assert len(here.comparisons) == 2 and measure.resolve_comparisons(sc, left.comparisons) == here.comparisons


def test_compiled_code_is_loaded_with_the_first_compiled_function():
    """The state that decides it: false after every import of a study (numba declares the functions then),
    true once one has been compiled or loaded from the cache. Run in a process of its own."""
    import subprocess
    import sys

    script = ("from xcheck._jit import compiled_code_loaded\nimport xcheck.study, xcheck.engines.mujoco\n"
              "before = compiled_code_loaded()\nimport numpy as np\nfrom xcheck.metrics import _errors\n"
              "_errors(np.ones((2, 4)), np.ones((2, 3)), np.ones((2, 4)), np.ones((2, 3)), np.empty(4))\n"
              "print(before, compiled_code_loaded())")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["False", "True"], out.stderr


def test_a_coarse_step_failure_is_worded_as_such(scenario):
    rs = runs(4)
    rs[0] = Run.failed(STEPS[0], "failed", "blew up", 0.0)
    st = assemble(scenario, STEPS, [result("lie-rkmk4", rs)])
    m = st.methods["lie-rkmk4"]
    assert m.status == "failed" and m.verdict == "pass" and m.status_text == "coarse step unstable"


def test_an_engine_equal_to_its_twin_agrees_where_the_steps_leave_both_above_the_limit():
    """Issue 37, 9: at steps too coarse for the 1e-9 rad agreement limit, MuJoCo's RK4 (on a ball joint, the same
    scheme as lie-rkmk4) was failed although the two agree to every digit. Truth: the twin's own trajectory at the
    same step — their difference is round-off (< 1e-9 rad) while both are ~1e-6 rad from Lagrange's top."""
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study

    st = run_study(resolve_scenario("heavy-top"), methods=["lie-rkmk4", "mujoco-rk4"], steps=[1 / 64, 1 / 128],
                   quick=True, workers=1, timing=False)
    check = next(c for c in st.checks if c.name == "agreement:mujoco-rk4")
    assert st.methods["mujoco-rk4"].finest.attitude_error > 1e-7  # both far above the limit at these steps
    assert check.passed and check.value < 1e-9 and "lie-rkmk4, the same scheme" in check.note, check


def test_the_bar_starts_before_the_first_run_ends(scenario):
    """A study's bar shows its first line (0 of its tasks, what is being done) before the reference's check and the
    first run, which on a first run compile for seconds (issue 61): every later call counts a finished task."""
    from xcheck.integrators import compile_cache_is_cold
    from xcheck.study import COMPILING

    calls = []
    said = COMPILING if compile_cache_is_cold() else "checking the reference"
    st = run_study(scenario, methods=["lie-rkmk4", "formulation-2"], steps=[0.125, 0.0625], workers=1, timing=False,
                   progress=lambda done, total, label: calls.append((done, total, label)))
    assert st.methods["lie-rkmk4"].runs
    assert calls[0] == (0, 2, said)
    assert [c[:2] for c in calls[1:]] == [(1, 2), (2, 2)]
    assert not compile_cache_is_cold()  # compiled now


def test_a_first_run_says_it_compiles(monkeypatch, tmp_path):
    """With an empty compile cache and no shipped code that fits (a machine that never ran this release, another
    Python) the first line says it compiles."""
    from xcheck import _jit, _prebuilt
    from xcheck.study import COMPILING, starting

    monkeypatch.setenv("XCHECK_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_prebuilt, "FOLDER", tmp_path / "no-archives")
    _jit.cache_root.cache_clear()
    try:
        calls = []
        starting(lambda *a: calls.append(a), 7)
        assert calls == [(0, 7, COMPILING)]
    finally:
        monkeypatch.undo()
        _jit.cache_root.cache_clear()
    assert not any(tmp_path.iterdir())  # saying so compiled nothing
