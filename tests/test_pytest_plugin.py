"""xcheck inside other people's pytest suites (issue 13): the plugin through pytester (collection and ids, a
failing check's message, a broken file among good ones, -k, xdist, JUnit XML, --xcheck-report), the assertion
helpers, and the example repository."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from xcheck import testing as T
from xcheck.paths import BUNDLED_MODELS
from xcheck.scenario import load_scenario, resolve_scenario
from xcheck.study import default_methods, planned_checks

pytest_plugins = ["pytester"]

GYRO = BUNDLED_MODELS / "scenarios" / "gyroscope-nonsingular.toml"
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "pytest-suite"


def _scenario_file(pytester, name="xcheck_gyro.toml", extra_checks=""):
    """The bundled gyroscope scenario as a user's file (the model path made absolute)."""
    text = GYRO.read_text().replace('"../gyroscope.xml"', f'"{(BUNDLED_MODELS / "gyroscope.xml").as_posix()}"')
    text = text.replace("[study]", "[study]\nmethods = [\"lie-rkmk4\", \"formulation-2\", \"mujoco-rk4\"]")
    if extra_checks:
        text += f"\n[checks]\n{extra_checks}\n"
    path = pytester.path / name
    path.write_text(text)
    return path


def _run(pytester, *args):
    return pytester.runpytest_subprocess("-p", "no:cacheprovider", "--xcheck-quick", *args)


def test_items_and_their_ids(pytester):
    """Truth: planned_checks of the scenario (quick: order and agreement, no final-error or invariants)."""
    _scenario_file(pytester)
    result = _run(pytester, "--co", "-q")
    ids = [line for line in result.outlines if "::" in line]
    assert ids == ["xcheck_gyro.toml::lie-rkmk4::runs", "xcheck_gyro.toml::lie-rkmk4::order",
                   "xcheck_gyro.toml::formulation-2::runs", "xcheck_gyro.toml::formulation-2::order",
                   "xcheck_gyro.toml::mujoco-rk4::runs", "xcheck_gyro.toml::mujoco-rk4::order",
                   "xcheck_gyro.toml::mujoco-rk4::agreement"]
    result = _run(pytester, "-q")
    result.assert_outcomes(passed=7)


def test_a_failing_check_says_what_was_measured(pytester):
    """An agreement limit no engine can meet (1e-16 rad): the item fails naming the method and the check, with the
    measured value, the limit, the steps, the reference and the report's line; the others pass."""
    _scenario_file(pytester, extra_checks="agreement = 1e-16")
    result = _run(pytester, "-q", "--junitxml=j.xml")
    result.assert_outcomes(passed=6, failed=1)
    text = result.stdout.str()
    assert "FAILED xcheck_gyro.toml::mujoco-rk4::agreement" in text
    assert "gyroscope-nonsingular: mujoco-rk4 agreement FAILED: worse of the two errors" in text
    assert "; limit 1e-16 rad" in text and "steps 1/64 … 1/1024 s (5 steps), exact reference, 10 s" in text
    assert "report: mujoco-rk4: at Δt = 1/1024 s attitude error" in text and "Traceback" not in text
    # JUnit XML for dashboards: the measured values in the failure's text
    root = ET.parse(pytester.path / "j.xml").getroot()
    failures = [(case.get("name"), case.find("failure")) for case in root.iter("testcase")
                if case.find("failure") is not None]
    assert len(failures) == 1 and failures[0][0] == "agreement"
    message = failures[0][1].get("message") + (failures[0][1].text or "")
    assert re.search(r"worse of the two errors [0-9.]+e-[0-9]+ rad; limit 1e-16 rad", message), message


def test_broken_files_are_one_failing_item_each_among_good_ones(pytester):
    """A broken scenario file, and (issue 37, 4) three broken xcheck_*.xml files, which once aborted the session
    ("Interrupted: 3 errors during collection") so that none of the good files ran: each is now one failing item with
    the CLI's refusal, and the good file's items pass. One run of pytest asks it of all four (issue 61)."""
    _scenario_file(pytester)
    (pytester.path / "xcheck_broken.toml").write_text('name = "broken"\nmodel = 3\n')
    (pytester.path / "xcheck_notxml.xml").write_text("<mujoco><worldbody><body>")
    (pytester.path / "xcheck_twojoints.xml").write_text(
        '<mujoco><worldbody><body><freejoint/><geom size="0.1" contype="0" conaffinity="0"/></body>'
        '<body pos="1 0 0"><freejoint/><geom size="0.1" contype="0" conaffinity="0"/></body></worldbody></mujoco>')
    (pytester.path / "xcheck_nanrate.xml").write_text(
        '<mujoco><option gravity="0 0 0"/><worldbody><body><freejoint/><inertial pos="0 0 0" mass="1" '
        'diaginertia="1 2 3"/></body></worldbody><keyframe><key qvel="0 0 0 nan 0 1"/></keyframe></mujoco>')
    result = _run(pytester, "-q")
    result.assert_outcomes(passed=7, failed=4)
    text = result.stdout.str()
    assert "errors during collection" not in text and "Interrupted" not in text, text
    assert "FAILED xcheck_broken.toml::scenario" in text
    assert "xcheck_broken.toml: model: expected a string, got int 3" in text  # the CLI's message
    for name, needle in (("notxml", "MuJoCo could not load it"), ("twojoints", "a multi-body model: 2 moving bodies"),
                         ("nanrate", "contains non-finite values")):
        assert f"FAILED xcheck_{name}.xml::scenario" in text and needle in text, (name, text)


def test_a_model_mujoco_cannot_load_fails_the_files_items_naming_it(pytester):
    """Collection reads the file without MuJoCo (issue 25); the model is loaded as the study starts, and a model
    MuJoCo refuses fails every item of the file with the CLI's message, naming the file and the model."""
    (pytester.path / "bad.xml").write_text("<mujoco><worldbody><body><geom type='sphere'/></mujoco>")
    text = GYRO.read_text().replace('"../gyroscope.xml"', '"bad.xml"')
    (pytester.path / "xcheck_badmodel.toml").write_text(text)
    result = _run(pytester, "-q", "-k", "lie-rkmk4")
    out = result.stdout.str()
    failed = result.parseoutcomes().get("failed", 0)
    assert failed >= 1 and result.parseoutcomes().get("passed", 0) == 0, out
    assert "xcheck_badmodel.toml: model:" in out and "bad.xml" in out, out


def test_k_selects_a_method_and_a_check(pytester):
    _scenario_file(pytester)
    result = _run(pytester, "-q", "-k", "mujoco-rk4 and order")
    result.assert_outcomes(passed=1, deselected=6)


def test_the_report_of_the_run_and_of_a_selection_that_runs_only_its_engines_methods_and_ours(pytester):
    """The report of the run (``--xcheck-report``), with every item and with ``-k lie-rkmk4``, which leaves MuJoCo's
    RK4 out of the study (an engine's method no selected item names), keeps every one of ours (``formulation-2`` too:
    the engines are compared with ours), and gives lie-rkmk4's and formulation-2's numbers of the full study bit for
    bit (truth: the same file's study with every item selected)."""
    import json

    _scenario_file(pytester)
    methods = {}
    for name, args, passed in (("all", (), 7), ("picked", ("-k", "lie-rkmk4"), 2)):
        result = _run(pytester, "-q", *args, "--xcheck-report", name)
        result.assert_outcomes(passed=passed, deselected=7 - passed)
        assert (pytester.path / name / "latest" / "index.html").is_file()
        assert "xcheck report: " in result.stdout.str()
        doc = json.loads((pytester.path / name / "latest" / "results.json").read_text())
        methods[name] = doc["scenarios"][0]["methods"]
    assert list(methods["all"]) == ["lie-rkmk4", "formulation-2", "mujoco-rk4"]
    assert list(methods["picked"]) == ["lie-rkmk4", "formulation-2"]
    for name in ("lie-rkmk4", "formulation-2"):
        full, picked = methods["all"][name], methods["picked"][name]
        assert [r["attitude_error"] for r in picked["runs"]] == [r["attitude_error"] for r in full["runs"]]
        assert picked["observed_order"] == full["observed_order"]


def test_under_xdist(pytester):
    """Two workers, a file per worker: the same items pass as without xdist (MuJoCo's callback is installed and
    restored around every run, in each worker's own process)."""
    pytest.importorskip("xdist")
    _scenario_file(pytester)
    _scenario_file(pytester, name="xcheck_gyro2.toml")
    result = _run(pytester, "-q", "-n", "2", "--dist", "loadfile")
    result.assert_outcomes(passed=14)


def test_an_ordinary_suite_is_left_alone(pytester):
    """Inactive until used: a suite without scenario files collects exactly its own tests."""
    pytester.makepyfile(test_plain="def test_one():\n    assert 1 + 1 == 2\n")
    (pytester.path / "settings.toml").write_text("x = 1\n")  # a .toml that is not a scenario file
    result = _run(pytester, "-q")
    result.assert_outcomes(passed=1)


def test_planned_checks_are_the_checks_a_study_makes():
    """Truth: the checks that real quick studies of every bundled scenario made, as the golden copy of the quick
    report keeps them (tests/data/quick-report.json; test_cli checks today's report against it), for the methods
    this machine has (the plugin's items are planned before the study runs; an order a step budget left undecided
    is the one check planned and not made, its item skipped saying so)."""
    import json

    from xcheck.runners import RUNNERS

    golden = json.loads((Path(__file__).parent / "data" / "quick-report.json").read_text())
    for doc in golden["scenarios"]:
        sc = resolve_scenario(doc["scenario"])
        methods = [m for m in default_methods(sc) if m in doc["methods"]]
        planned = set(planned_checks(sc, methods, quick=True))
        files = {c.name for c in sc.trajectories}  # a trajectory file's check: named as a method's is
        made = {(c["name"].split(":", 1)[1], c["name"].split(":", 1)[0]) for c in doc["checks"].values()
                if ":" in c["name"] and c["name"].split(":", 1)[1] in (*RUNNERS, *files)}
        # an order the steps run could not decide, where a step budget left the deciding ones out: no claim made
        undecided = {(m, "order") for m, left in (doc.get("over_budget") or {}).items()
                     if "order is not measured" in left["why"]}
        assert made <= planned, (sc.name, made - planned)
        assert {p for p in planned if p[1] != "runs"} - undecided <= made, sc.name


# ------------------------------------------------------------------------------------------------------
# the helpers
# ------------------------------------------------------------------------------------------------------
def test_assert_converges():
    """Truth: lie-rkmk4 is order 4; the printed algorithm 172 is order 2 (the seed 004 finding)."""
    st = T.assert_converges("gyroscope-nonsingular", method="lie-rkmk4", order=4, tol=0.3)
    assert abs(st.methods["lie-rkmk4"].observed_order - 4) < 0.3
    with pytest.raises(T.XcheckAssertionError) as err:
        T.assert_converges("tumbler-intermediate-axis", method="lie-thesis-172", order=4, tol=0.3)
    text = str(err.value)
    assert "lie-thesis-172 does not converge at order 4 ± 0.3: observed 2" in text
    assert "steps 1/64 … 1/1024 s (5 steps), exact reference" in text and "report: lie-thesis-172:" in text


def test_assert_matches_reference():
    run = T.assert_matches_reference("gyroscope-nonsingular", method="mujoco-rk4", dt=1 / 256, atol=1e-9)
    assert run.max_attitude_error < 1e-9
    with pytest.raises(T.XcheckAssertionError, match=r"mujoco-euler at Δt = 0.00390625 s is not within 1e-06 rad "
                                                     r"of the exact reference: largest attitude error over the run"):
        T.assert_matches_reference("gyroscope-nonsingular", method="mujoco-euler", dt=1 / 256, atol=1e-6)


def test_assert_agrees():
    """Truth: MuJoCo's RK4 and our RKMK4 are both fourth order: at 1/256 s they agree far below 1e-9 rad; MuJoCo's
    Euler does not."""
    assert T.assert_agrees("gyroscope-nonsingular", "mujoco-rk4", "lie-rkmk4", dt=1 / 256, atol=1e-9) < 1e-9
    with pytest.raises(T.XcheckAssertionError, match="mujoco-euler and lie-rkmk4 at Δt = 0.00390625 s differ by"):
        T.assert_agrees("gyroscope-nonsingular", "mujoco-euler", "lie-rkmk4", dt=1 / 256, atol=1e-6)


def test_assert_invariants():
    drift = T.assert_invariants("tumbler-intermediate-axis", method="lie-rkmk4", dt=1 / 512, rtol=1e-9)
    assert abs(drift["energy_change"]) < 1e-9 and abs(drift["momentum_change"]) < 1e-9 and drift["momentum_turn"] < 1e-9
    # implicitfast damps the tumbler: energy -0.0045 and |L| -0.00225 over 10 s at 1/512 s, L turned 0.00153 rad
    with pytest.raises(T.XcheckAssertionError, match=r"mujoco-implicitfast .*: energy -0\.0045 \(damped\), beyond "
                       r"±1e-06; \|L\| -0\.00225 \(damped\), beyond ±1e-06; L's direction turned 0\.00153 rad"):
        T.assert_invariants("tumbler-intermediate-axis", method="mujoco-implicitfast", dt=1 / 512, rtol=1e-6)
    with pytest.raises(ValueError, match="has a \\[torque\\]"):
        T.assert_invariants("rax1-orbit-field", method="lie-rkmk4")


def test_the_example_repository_passes(tmp_path):
    """examples/pytest-suite, copied out of this repository as a user's own: pytest there, with nothing but
    xcheck installed, collects its scenario files and its hand-written test, and they pass."""
    dest = tmp_path / "team-repo"
    shutil.copytree(EXAMPLE, dest)
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], cwd=dest,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "18 passed" in proc.stdout
    assert load_scenario(dest / "xcheck_tumble.toml").model.name == "satellite.xml"


def test_an_unwritable_report_folder_is_a_usage_error_before_the_tests(pytester):
    """Issue 24, item 9: --xcheck-report onto a file: pytest's usage error (exit 4), no test run, no INTERNALERROR."""
    _scenario_file(pytester)
    (pytester.path / "taken").write_text("a file, not a folder")
    result = _run(pytester, "-q", "--xcheck-report", str(pytester.path / "taken"))
    assert result.ret == 4, result.stdout.str() + result.stderr.str()
    err = result.stderr.str()
    assert "--xcheck-report: " in err and "is a file; expected a folder" in err and "INTERNALERROR" not in err
    assert "passed" not in result.stdout.str()


def test_two_files_of_one_scenario_name_are_refused_for_a_report(pytester):
    """Issue 24, item 9: their sections and figures in --xcheck-report would be written over each other (the CLI
    refuses it too); without a report they are two tests like any (test_under_xdist)."""
    first = _scenario_file(pytester, "xcheck_a.toml")
    second = _scenario_file(pytester, "xcheck_b.toml")
    result = _run(pytester, "-q", "-k", "scenario", "--xcheck-report", "rep")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert f"the scenario name 'gyroscope-nonsingular' is also {first}'s" in out and str(second) in out, out


def test_a_model_alone_is_collected_as_a_scenario(pytester):
    """Issue 26: an ``xcheck_*.xml`` MJCF file is collected with the scenario ``xcheck init`` would write for it
    (its first keyframe's state, torque free, the exact reference): items ``<file>::<method>::<check>``."""
    keyframe = '<keyframe><key name="spin" qpos="0 0 0 1 0 0 0" qvel="0 0 0 0.1 0.5 1.0"/></keyframe></mujoco>'
    text = (BUNDLED_MODELS / "tumbler.xml").read_text().replace("</mujoco>", keyframe)
    (pytester.path / "xcheck_sat.xml").write_text(text)
    result = _run(pytester, "-v", "-k", "lie-rkmk4")
    result.assert_outcomes(passed=2)  # quick: runs and order
    out = result.stdout.str()
    assert "xcheck_sat.xml::lie-rkmk4::order PASSED" in out and "xcheck_sat.xml::lie-rkmk4::runs PASSED" in out


def test_a_check_that_cannot_decide_is_a_skipped_item_that_says_why(pytester):
    """Issue 36: INCONCLUSIVE is neither passed nor failed: a body at rest (a vacuous study) makes every item a skip
    whose reason says 'INCONCLUSIVE: vacuous', shown by -ra; the run passes (no failure)."""
    path = pytester.path / "xcheck_still.toml"
    path.write_text(f'name = "still"\nmodel = "{(BUNDLED_MODELS / "tumbler.xml").as_posix()}"\nduration = 2.0\n'
                    '[initial]\nquaternion = [1, 0, 0, 0]\nangular_velocity = [0, 0, 0]\n[study]\n'
                    'methods = ["lie-rkmk4"]\nquick_steps = [0.25, 0.125, 0.0625]\n')
    result = _run(pytester, "-ra")
    result.assert_outcomes(skipped=2)
    assert "INCONCLUSIVE: vacuous: the body is at rest" in result.stdout.str()
