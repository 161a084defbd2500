"""The user's own step (issue 59): a model's ``<option timestep>`` (MuJoCo's default 0.002 s where it sets none) is
one of the study's steps, the derived ladders bracket it, the model's integrator is named first among MuJoCo's
methods, and an order is still fitted on the ladder of halvings. Truths: the MJCF as written, MuJoCo's documented
default step (``mjOption.timestep`` = 0.002 s), and errors of a known order."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

#: A free box at 0.01 s with MuJoCo's implicitfast, turning about all three axes (a MuJoCo forum question: does
#: implicitfast lose energy at 0.01 s?).
BOX = (Path(__file__).parent / "data" / "free_box.xml").read_text()  # shared with test_invariants


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    folder = tmp_path_factory.mktemp("your-step")
    (folder / "box.xml").write_text(BOX)
    (folder / "plain.xml").write_text(BOX.replace('  <option timestep="0.01" integrator="implicitfast" '
                                                  'gravity="0 0 0"/>\n', ""))
    return folder


def _brackets(steps, step) -> bool:
    return step in steps and min(steps) < step < max(steps)


def test_a_models_own_step_is_studied_and_bracketed(models):
    """0.01 s (not a power of two) is one of the full and the quick steps, exactly, with steps on both sides."""
    from xcheck.scenario import resolve_scenario

    sc = resolve_scenario(str(models / "box.xml"))
    assert sc.your_step == 0.01 and sc.your_step_why == "the model's <option timestep>"
    assert sc.your_integrator == "implicitfast"
    assert _brackets(sc.steps, 0.01) and _brackets(sc.quick_steps, 0.01)
    assert any("your step 0.01 s (the model's <option timestep>)" in a for a in sc.assumptions)


def test_mujocos_default_step_where_the_mjcf_sets_none(models):
    """No <option timestep>: MuJoCo's default, 0.002 s, and its default integrator Euler, said as such."""
    from xcheck.scenario import resolve_scenario

    sc = resolve_scenario(str(models / "plain.xml"))
    assert sc.your_step == 0.002 and sc.your_integrator == "euler"
    assert sc.your_step_why == "MuJoCo's default step: the MJCF sets no <option timestep>"
    assert _brackets(sc.steps, 0.002) and _brackets(sc.quick_steps, 0.002)


def test_the_models_integrator_is_first_among_mujocos(models):
    from xcheck.scenario import resolve_scenario
    from xcheck.study import default_methods

    mujoco = [m for m in default_methods(resolve_scenario(str(models / "box.xml"))) if m.startswith("mujoco-")]
    assert mujoco[:2] == ["mujoco-implicitfast", "mujoco-rk4"]  # the others keep their order
    plain = [m for m in default_methods(resolve_scenario(str(models / "plain.xml"))) if m.startswith("mujoco-")]
    assert plain[0] == "mujoco-euler"


def test_a_scenario_file_deriving_its_steps_takes_its_models_step(models, tmp_path):
    """A scenario file that leaves its steps out gets the model's step among the derived ones; one that writes its
    steps keeps them (they are the user's own choice), the model's step still known."""
    from xcheck.scenario import load_scenario

    body = ('model = "{}"\nduration = 10.0\n[initial]\nquaternion = [1.0, 0.0, 0.0, 0.0]\n'
            'angular_velocity = [0.3, 2.0, 0.5]\n').format((models / "box.xml").as_posix())
    (tmp_path / "derived.toml").write_text(f'name = "derived"\n{body}')
    sc = load_scenario(tmp_path / "derived.toml")
    assert _brackets(sc.steps, 0.01) and _brackets(sc.quick_steps, 0.01)
    (tmp_path / "written.toml").write_text(f'name = "written"\n{body}[study]\nsteps = [0.5, 0.25, 0.125]\n'
                                           'quick_steps = [0.5, 0.25, 0.125]\n')
    sc = load_scenario(tmp_path / "written.toml")
    assert sc.steps == (0.5, 0.25, 0.125) and sc.your_step == 0.01


@pytest.mark.parametrize("step, expected, said", [
    (2.0**-6, (2.0**-4, 2.0**-5, 2.0**-6, 2.0**-7), ""),  # a step of the ladder: nothing added
    (0.01, (2.0**-4, 2.0**-5, 2.0**-6, 0.01, 2.0**-7), "and your step 0.01 s"),
    (0.1, (0.2, 0.1, 2.0**-4, 2.0**-5, 2.0**-6, 2.0**-7), "with 0.2 s beyond it"),  # coarser: twice it added
    (0.005, (2.0**-4, 2.0**-5, 2.0**-6, 2.0**-7, 0.005, 0.0025), "with 0.0025 s beyond it"),  # finer: half of it
    (20.0, (2.0**-4, 2.0**-5, 2.0**-6, 2.0**-7), "longer than the duration"),
])
def test_with_your_step(step, expected, said):
    from xcheck.defaults import with_your_step

    ladder, words = with_your_step((2.0**-4, 2.0**-5, 2.0**-6, 2.0**-7), step, 10.0)
    assert ladder == expected and said in words


def test_an_order_is_fitted_on_the_ladder_not_on_the_added_step():
    """Errors C dt^4 on 1/16 … 1/256 s, and at 0.01 s (plus 0.02 s) an error off that law by 20 %: the fit on the
    ladder is 4 to 1e-12 at every pair; with the added steps its local orders would be 3.6 and 4.7."""
    from xcheck.metrics import ladder_steps, observed_order

    ladder = [2.0**-k for k in range(4, 9)]
    steps = sorted(ladder + [0.02, 0.01], reverse=True)
    assert ladder_steps(steps, 0.01) == ladder
    assert ladder_steps(ladder, 2.0**-6) == ladder  # the user's step on the ladder: every step
    assert ladder_steps(steps, None) == steps
    assert ladder_steps([0.3, 0.2, 0.1, 0.01], 0.01) == [0.3, 0.2, 0.1, 0.01]  # no ladder to keep: every step
    errors = {d: 1e-2 * d**4 * (1.2 if d in (0.02, 0.01) else 1.0) for d in steps}
    kept = ladder_steps(steps, 0.01)
    fit = observed_order(kept, [errors[d] for d in kept], floor=1e-16)
    assert fit.order == pytest.approx(4.0, abs=1e-12)
    assert max(abs(p - 4.0) for p in fit.local_orders) < 1e-12
    every = observed_order(steps, [errors[d] for d in steps], floor=1e-16)  # with them: local orders 3.6 and 4.7
    assert max(abs(p - 4.0) for p in every.local_orders) > 0.5


def test_a_study_runs_every_method_at_the_models_step(models):
    """Every method has a run at 0.01 s; lie-rkmk4's order is 4 (within the study's 0.3), fitted without it."""
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study

    sc = resolve_scenario(str(models / "box.xml"))
    st = run_study(sc, methods=["lie-rkmk4", "mujoco-implicitfast"], quick=True, workers=1, timing=False)
    for name, m in st.methods.items():
        assert [r.setting for r in m.runs if r.setting == 0.01], name
    lie = st.methods["lie-rkmk4"]
    assert abs(lie.observed_order - 4) <= 0.3
    assert "0.01" not in lie.order_note
    at = next(r for r in st.methods["mujoco-implicitfast"].runs if r.setting == 0.01)
    assert np.isfinite(at.attitude_error) and at.attitude_error > 1e-4  # a first-order method at 0.01 s


def test_the_first_line_answers_at_the_models_step(models):
    """The answer is read from the runs at 0.01 s (the largest attitude error over the run, against [checks]
    tolerance 1e-6 rad), the model's integrator first; it leads the terminal's lines and the JSON."""
    from xcheck.commands.studies import study_lines
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study
    from xcheck.study.your_step import answer_line

    sc = resolve_scenario(str(models / "box.xml"))
    st = run_study(sc, methods=["lie-rkmk4", "mujoco-implicitfast", "scipy-rk45"], quick=True, workers=1,
                   timing=False)
    a = st.data["your_step"]
    assert (a["dt"], a["duration"], a["tolerance"], a["integrator"], a["studied"]) == (0.01, sc.duration, 1e-6,
                                                                                        "implicitfast", True)
    for name in ("lie-rkmk4", "mujoco-implicitfast"):
        run = next(r for r in st.methods[name].runs if r.dt == 0.01)
        assert a["methods"][name] == {"error": run.max_attitude_error, "within": run.max_attitude_error <= 1e-6,
                                      "energy_change": run.energy_change, "momentum_change": run.momentum_change,
                                      "momentum_turn": run.momentum_turn, "energy_law": run.energy_law,
                                      "momentum_law": run.momentum_law, "turn_law": run.turn_law,
                                      "flips": run.flips}  # the box tumbles: it flips every 6.2 s
        assert run.flips["flips"] == 3
    assert a["methods"]["mujoco-implicitfast"]["energy_change"] < 0 < a["methods"]["mujoco-implicitfast"]["momentum_turn"]
    assert a["methods"]["lie-rkmk4"]["within"] and not a["methods"]["mujoco-implicitfast"]["within"]
    assert a["not_run"] == {"scipy-rk45": "adaptive: it chooses its own steps (see its tolerances)"}
    line = answer_line(a)
    e = a["methods"]["mujoco-implicitfast"]["error"]
    assert line.startswith(f"at your Δt = 0.01 s (the model's <option timestep>) over {sc.duration:g} s, largest "
                           f"attitude error over the run: mujoco-implicitfast {e:.2g} rad (tolerance 1e-06: not "
                           "within), damps energy (")
    assert "; 1 of 2 methods within, the best lie-rkmk4" in line
    assert study_lines(st)[1] == f"  {line}"


def test_a_scenario_whose_steps_leave_out_the_models_says_so(models, tmp_path):
    from xcheck.scenario import load_scenario
    from xcheck.study import run_study
    from xcheck.study.your_step import answer_line

    (tmp_path / "written.toml").write_text(
        f'name = "written"\nmodel = "{(models / "box.xml").as_posix()}"\nduration = 2.0\n[initial]\n'
        'quaternion = [1.0, 0.0, 0.0, 0.0]\nangular_velocity = [0.3, 2.0, 0.5]\n'
        '[study]\nsteps = [0.0625, 0.03125, 0.015625]\n'
        'quick_steps = [0.0625, 0.03125, 0.015625]\n')
    st = run_study(load_scenario(tmp_path / "written.toml"), methods=["lie-rkmk4"], quick=True, workers=1,
                   timing=False)
    assert st.your_step["studied"] is False and st.your_step["methods"] == {}
    assert "not studied — the scenario writes its steps (1/16, 1/32, 1/64 s) and yours is not among them" in \
        answer_line(st.your_step)


@pytest.mark.parametrize("text, seconds", [("10", 10.0), ("10 s", 10.0), ("10s", 10.0), ("2 min", 120.0),
                                           ("1 h", 3600.0), ("1.5h", 5400.0), ("1 d", 86400.0)])
def test_duration_units(text, seconds):
    from xcheck.commands.arguments import duration_arg

    assert duration_arg(text) == seconds


@pytest.mark.parametrize("command", [["converge", "{box}", "--quick"], ["report", "{box}", "--quick", "--out", "{out}"],
                                     ["run", "{box}", "--method", "lie-rkmk4", "--dt", "0.01"],
                                     ["init", "{box}", "--out", "{out}/x.toml"], ["horizon", "{box}"]])
@pytest.mark.parametrize("bad", ["0", "-3", "abc", "10 days", "nan"])
def test_every_command_refuses_a_bad_duration_alike(models, tmp_path, capsys, command, bad):
    """One rule and one message for --duration in every command that takes it: exit 2, naming the argument, before
    anything is written."""
    from xcheck.cli import main

    args = [a.format(box=models / "box.xml", out=tmp_path) for a in command]
    assert main([*args, f"--duration={bad}"]) == 2
    err = capsys.readouterr().err
    assert f"--duration: expected a positive time, seconds, or with a unit (10, 10 s, 2 min, 1 h, 1 d), got {bad!r}" \
        in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("command", [["converge", "{box}", "--quick"], ["run", "{box}", "--method", "lie-rkmk4",
                                                                        "--dt", "0.01"]])
def test_a_duration_past_the_step_budget_is_refused_naming_it(models, capsys, command):
    from xcheck.cli import main

    assert main([*(a.format(box=models / "box.xml") for a in command), "--duration", "1e12 s"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("xcheck: error: --duration 1e12 s: ") and "limit of" in err


def test_duration_sets_the_run_and_keeps_the_models_step(models, tmp_path):
    """A model alone over --duration 10 s: the study's duration is 10 s, the model's 0.01 s still studied and
    bracketed; a bundled scenario's written steps longer than a short duration are left out; init writes it."""
    from xcheck.cli import main
    from xcheck.commands.arguments import user_scenario

    sc = user_scenario(str(models / "box.xml"), "10 s")
    assert sc.duration == 10.0 and _brackets(sc.steps, 0.01) and _brackets(sc.quick_steps, 0.01)
    gyro = user_scenario("gyroscope-nonsingular", "0.3")
    assert gyro.duration == 0.3 and max(gyro.steps) <= 0.3 and min(gyro.steps) == 2.0**-12
    assert main(["init", str(models / "box.xml"), "--out", str(tmp_path / "b.toml"), "--duration", "1 min"]) == 0
    assert "duration = 60.0   # [s], yours (--duration)" in (tmp_path / "b.toml").read_text()


@pytest.mark.parametrize("command", ["converge", "report", "run", "horizon", "releases", "score", "init"])
def test_every_commands_help_names_what_it_takes(command, capsys):
    """Each command that takes a scenario says it takes a model too (MODEL.xml), and those with --duration its
    units."""
    from xcheck.cli import main

    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "MODEL.xml" in text
    if command in ("converge", "report", "run", "horizon", "init"):
        assert "--duration" in text and "(10, 10 s, 2 min, 1 h, 1 d)" in text
