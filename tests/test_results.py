"""Typed results (xcheck.results) and the verdicts the study computes once: a run's JSON keeps the keys of schema
xcheck.convergence/3, a method's status and finest run follow from its runs, a check's name is kind:method."""

from xcheck.results import Check, MethodResult, Run, json_number
from xcheck.study.checks import verdict

RUN_KEYS = {"dt", "status", "attitude_error", "max_attitude_error", "omega_error", "max_omega_error", "energy_change",
            "momentum_change", "momentum_turn", "norm_drift", "wall_time", "steps_per_second", "repeats",
            "evaluations"}


def test_run_json_keys():
    assert set(Run(0.5, attitude_error=1e-3).to_json()) == RUN_KEYS
    failed = Run.failed(0.25, "singular", "stopped", 0.1)
    assert set(failed.to_json()) == RUN_KEYS | {"message"} and failed.to_json()["message"] == "stopped"
    assert not failed.ok and failed.attitude_error is None


def test_method_status_and_finest():
    m = MethodResult("x", "xcheck", 4, runs=[Run(0.5, attitude_error=1e-3), Run(0.25, attitude_error=6e-5),
                                               Run.failed(0.125, "failed", "blew up", 0.0)])
    assert m.status == "failed" and m.finest.dt == 0.25
    m.runs[2] = Run.failed(0.125, "singular", "gimbal lock", 0.0)
    assert m.status == "singular"
    assert MethodResult("y", "xcheck", 4, runs=[Run.failed(0.5, "failed", "", 0.0)]).finest is None
    assert MethodResult("z", "mujoco", 1, runs=[Run(0.5)]).status == "ok"


def test_check_name_and_json():
    c = Check("order", True, "lie-rkmk4", 3.99, 4, "median")
    assert c.name == "order:lie-rkmk4" and Check("reference", False).name == "reference"
    assert c.to_json() == {"name": "order:lie-rkmk4", "passed": True, "status": "pass", "value": 3.99, "limit": 4.0,
                           "note": "median"}
    undecided = Check("order", False, "mujoco-euler", None, 1, "pre-asymptotic", inconclusive=True)
    assert undecided.status == "inconclusive" and not undecided.failed and undecided.to_json()["passed"] is False
    assert json_number(float("nan")) is None and json_number(float("inf")) is None and json_number(2) == 2.0


def test_verdicts():
    checks = [Check("order", True, "a"), Check("final-error", False, "b"), Check("order", True, "b"),
              Check("expected-failure", True, "c"), Check("expected-failure", False, "d")]
    assert [verdict(m, checks) for m in "abcde"] == ["pass", "fail", "expected", "fail", "info"]
    assert verdict("a", checks + [Check("reference", False)]) == "fail"
