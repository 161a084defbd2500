"""Issue 26: an MJCF file wherever a scenario is accepted, and ``xcheck init``.

Truths: the keyframe's own numbers (a free joint's qpos holds the quaternion body -> world at 3..6, its qvel the
body-frame rate at 3..5: MuJoCo's convention, which xcheck's MuJoCo engine reads back after a step); the bundled
tumbler scenario, whose state the keyframe below holds (its study's numbers must be the same bit for bit); the
MJCF body's own ``quat`` where there is no keyframe."""

import json
import math

import numpy as np
import pytest

from xcheck.cli import main
from xcheck.models import DEFAULT_RATE
from xcheck.paths import BUNDLED_MODELS
from xcheck.scenario import ScenarioError, load_scenario, resolve_scenario

TUMBLER = BUNDLED_MODELS / "tumbler.xml"
S = math.sqrt(0.5)
KEYFRAMES = """
  <keyframe>
    <key name="spin" qpos="0 0 0 0.7071067811865476 0.7071067811865476 0 0" qvel="0.5 0 0 0.02 2.0 0.03"/>
    <key name="still" qpos="0 0 0 1 0 0 0"/>
  </keyframe>
"""


def _model(tmp_path, name="satellite.xml", keyframes=KEYFRAMES, quat=None):
    text = TUMBLER.read_text()
    if quat is not None:
        text = text.replace("<body ", f'<body quat="{quat}" ', 1)
    text = text.replace("</mujoco>", keyframes + "</mujoco>")
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_first_keyframe_is_the_initial_state(tmp_path):
    sc = resolve_scenario(str(_model(tmp_path)))
    # the keyframe's quaternion, normalised as the scenario reader normalises the bundled file's same digits
    np.testing.assert_array_equal(sc.q0, resolve_scenario("tumbler-intermediate-axis").q0)
    np.testing.assert_allclose(sc.q0, [S, S, 0.0, 0.0], rtol=0, atol=2e-16)
    np.testing.assert_array_equal(sc.omega0, [0.02, 2.0, 0.03])
    said = " | ".join(sc.assumptions)
    # the duration shows the body's own motion (issue 36): the tumble's period is 17.7 s (its elliptic period)
    assert sc.torque is None and sc.reference == "exact" and sc.duration == 20.0 and "periods (17.7 s" in said
    assert "keyframe 'spin' (the first of the model's)" in said
    assert "translational velocity [0.5, 0.0, 0.0] m/s is left out" in said


def test_a_keyframe_by_name_and_one_the_model_lacks(tmp_path, capsys):
    path = _model(tmp_path)
    sc = resolve_scenario(f"{path}#still")
    np.testing.assert_array_equal(sc.omega0, [0.0, 0.0, 0.0])
    assert sc.name == "satellite-still" and "does not turn" in " ".join(sc.assumptions)
    assert main(["converge", f"{path}#wobble", "--quick"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: no keyframe named 'wobble' (its keyframes: spin, still)" in err and "Traceback" not in err


def test_a_model_without_keyframe_keeps_its_pose_at_the_default_rate(tmp_path):
    sc = resolve_scenario(str(_model(tmp_path, keyframes="", quat="0 1 0 0")))
    np.testing.assert_allclose(sc.q0, [0.0, 1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(sc.omega0, DEFAULT_RATE)
    assert "no <keyframe>" in sc.assumptions[0]


def test_the_keyframe_reaches_every_engine(tmp_path):
    """The first sample of each engine's run is the keyframe's state (xcheck's MuJoCo engine writes qpos/qvel and
    reads them back; Basilisk's through its MRP set)."""
    from xcheck.runners import RUNNERS
    from xcheck.study.context import run_context

    sc = resolve_scenario(str(_model(tmp_path)))
    ctx = run_context(sc)
    engines = [m for m in ("mujoco-rk4", "basilisk-rk4", "lie-rkmk4") if m in RUNNERS]
    for m in engines:
        traj = RUNNERS[m].run(ctx, 0.125)
        np.testing.assert_allclose(traj.q[0], [S, S, 0.0, 0.0], rtol=0, atol=1e-15, err_msg=m)
        np.testing.assert_allclose(traj.omega[0], [0.02, 2.0, 0.03], rtol=0, atol=1e-15, err_msg=m)


def test_the_model_alone_gives_the_bundled_scenarios_numbers(tmp_path):
    """The keyframe holds the bundled tumbler's state: over the bundled scenario's duration and quick steps (the model
    alone derives its own), its quick study's errors are the same, bit for bit, for every method but euler-rk4
    (whose Euler sequence the MJCF path chooses itself)."""
    import dataclasses

    from xcheck.study import run_study

    methods = ["lie-rkmk4", "formulation-2", "mujoco-rk4"]
    bundled = resolve_scenario("tumbler-intermediate-axis")
    alone = dataclasses.replace(resolve_scenario(str(_model(tmp_path))), duration=bundled.duration,
                                quick_steps=bundled.quick_steps)
    a = run_study(alone, methods=methods, quick=True, workers=1, timing=False)
    b = run_study(bundled, methods=methods, quick=True, workers=1, timing=False)
    for m in methods:
        assert [r.attitude_error for r in a.methods[m].runs] == [r.attitude_error for r in b.methods[m].runs], m
    assert a.passed


def test_a_refused_model_says_why(tmp_path, capsys):
    bad = tmp_path / "hinged.xml"
    bad.write_text("<mujoco><worldbody><body><joint type='hinge'/><geom size='0.1' mass='1'/></body></worldbody>"
                   "</mujoco>")
    assert main(["report", str(bad), "--quick", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert f"{bad}: joint '#0' is a hinge joint with no free body to carry it" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").rglob("index.html"))


def test_init_writes_the_scenario_the_model_path_runs(tmp_path, capsys, monkeypatch):
    (tmp_path / "models").mkdir()
    path = _model(tmp_path / "models")
    monkeypatch.chdir(tmp_path)
    assert main(["init", str(path)]) == 0
    written = tmp_path / "xcheck_satellite.toml"
    text = written.read_text()
    assert 'model = "models/satellite.xml"' in text and "[checks]" in text and "# [torque]" in text
    from_file, from_model = load_scenario(written), resolve_scenario(str(path))
    for key in ("name", "duration", "sequence", "torque", "steps", "quick_steps", "tolerances", "quick_tolerances",
                "adaptive_step", "methods", "reference", "reference_method", "reference_dt", "checks"):
        assert getattr(from_file, key) == getattr(from_model, key), key
    np.testing.assert_array_equal(from_file.q0, from_model.q0)
    np.testing.assert_array_equal(from_file.omega0, from_model.omega0)
    assert from_file.model.resolve() == path.resolve()
    from xcheck.study import run_study

    a, b = (run_study(sc, methods=["lie-rkmk4", "mujoco-rk4"], steps=[0.25, 0.125], workers=1, timing=False)
            for sc in (from_file, from_model))
    def numbers(doc):  # every number but the times
        if isinstance(doc, dict):
            return {k: numbers(v) for k, v in doc.items() if k not in ("wall_time", "steps_per_second", "repeats")}
        return [numbers(v) for v in doc] if isinstance(doc, list) else doc

    assert numbers(a.data["methods"]) == numbers(b.data["methods"])  # the same study, bit for bit
    assert main(["init", str(path)]) == 2  # it does not replace a file unasked
    assert "exists; give another --out, or --force" in capsys.readouterr().err
    assert main(["init", str(path), "--force", "--keyframe", "still"]) == 0
    assert load_scenario(written).omega0.tolist() == [0.0, 0.0, 0.0]


def test_a_report_of_a_model_states_its_assumptions(tmp_path):
    path = _model(tmp_path)
    out = tmp_path / "r"
    assert main(["report", str(path), "--quick", "--workers", "1", "--out", str(out)]) == 0
    results = json.loads((out / "latest" / "results.json").read_text())
    said = results["scenarios"][0]["assumptions"]
    assert any("keyframe 'spin'" in a for a in said) and any("torque free" in a for a in said)
    html = (out / "latest" / "index.html").read_text()
    assert "Assumed from the MJCF alone" in html and ("keyframe &#x27;spin&#x27;" in html or "keyframe 'spin'" in html)


def test_a_model_file_is_not_read_as_a_scenario_file(tmp_path):
    with pytest.raises(ScenarioError, match="an MJCF file, not a scenario file"):
        load_scenario(_model(tmp_path))


def test_a_sweep_and_the_nightly_take_a_model_as_their_base(tmp_path):
    """A sweep's ``base`` may be an MJCF file beside the spec (its keyframe by ``#name``); the report and the
    nightly resolve their scenario arguments the same way."""
    from xcheck.report.build import resolve_scenarios
    from xcheck.sweep.spec import load_sweep

    path = _model(tmp_path)
    spec = tmp_path / "swap.toml"
    spec.write_text(f'base = "{path.name}#spin"\n[axes.rate_scale]\nvalues = [0.5, 2.0]\n')
    sweep = load_sweep(spec)
    np.testing.assert_array_equal(sweep.base.omega0, [0.02, 2.0, 0.03])
    assert sweep.base.assumptions and len(sweep.cells) == 2
    (sc,) = resolve_scenarios([f"{path}#still"])
    assert sc.name == "satellite-still" and sc.omega0.tolist() == [0.0, 0.0, 0.0]
