"""The report's horizon section (issue 41; ``xcheck report --horizon``): each scenario with a ``[horizon]`` table run
over its long duration, in parts shared by the pool's worker and this process, its table stating per method and
step how long each stays within 1e-6 and 1e-3 rad, its figure, its keys in results.json; absent without the flag."""

from __future__ import annotations

import json

import pytest

from xcheck.cli import main
from xcheck.paths import BUNDLED_MODELS
from xcheck.report.horizons import PARTS
from xcheck.study.horizon import horizon_methods


def _short_horizon(tmp_path, name="tumbler-short-horizon"):
    """The bundled tumbler with a horizon of 100 s (about six tumbles) at 1/16 and 1/32 s: a second's work."""
    text = (BUNDLED_MODELS / "scenarios" / "tumbler-intermediate-axis.toml").read_text()
    text = text.replace('name = "tumbler-intermediate-axis"', f'name = "{name}"')
    text = text.replace('model = "../tumbler.xml"', f'model = "{BUNDLED_MODELS / "tumbler.xml"}"')
    text = text.replace("duration = 17400.0", "duration = 100.0").replace(
        "steps = [0.0625, 0.03125, 0.015625]", "steps = [0.0625, 0.03125]")
    # the report's quick study of two methods (ours and MuJoCo's RK4, the agreement check): the horizon's methods
    # are its own, every fixed-step one installed (horizon_methods), and the study's are not what is tested here
    text = text.replace("[study]\n", '[study]\nmethods = ["lie-rkmk4", "mujoco-rk4"]\n', 1)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("workers", [1, 2])
def test_the_report_runs_the_horizons_when_asked(tmp_path, workers):
    """Truth: the tumbler's closed form at any time. Every default method at both steps, in the methods' order,
    whether its parts ran in the worker or here: RK4 methods' errors grow (p > 0.8) and leave 1e-6 rad within the
    run at 1/16 s; the splittings are the exact flow (1.2e-11 rad after six tumbles near the separatrix), within 1e-6
    rad for the whole 100 s. The section is in the
    HTML with its figure, and its verdict joins the report's."""
    scenario = _short_horizon(tmp_path)
    out = tmp_path / "reports"
    code = main(["report", "--quick", "--horizon", "--workers", str(workers), "--out", str(out), str(scenario)])
    assert code in (0, 1)  # the quick study of the engines' methods on this body is not what is tested here
    (folder,) = [p for p in out.iterdir() if p.is_dir() and not p.is_symlink()]
    doc = json.loads((folder / "results.json").read_text())
    section = doc["horizons"]
    assert section["passed"] and not section["refused"], (section["refused"], section.get("failed"), [
        (line["method"], line["dt"], line["message"]) for st in section["studies"] for line in st.get("lines", [])
        if line["status"] != "ok"])
    (study,) = section["studies"]
    assert study["scenario"] == "tumbler-short-horizon" and study["duration"] == 100.0
    methods = horizon_methods()
    got = [(line["method"], line["dt"]) for line in study["lines"]]
    assert sorted(got) == sorted((m, dt) for m in methods for dt in (0.0625, 0.03125))
    named = list(dict.fromkeys(m for m, _ in got))  # each method's lines together, coarse to fine
    assert got == [(m, dt) for m in named for dt in (0.0625, 0.03125)]
    by = {(line["method"], line["dt"]): line for line in study["lines"]}
    rk = by["lie-rkmk4", 0.0625]
    assert rk["status"] == "ok" and rk["growth"] > 0.8 and rk["within"]["1e-06"] < 100.0
    for m in ("split-strang", "split-yoshida4"):
        assert by[m, 0.0625]["within"]["1e-06"] == 100.0 and by[m, 0.0625]["final_error"] < 1e-10  # 1.2e-11
    html = (folder / "index.html").read_text()
    assert "id='horizons'" in html and "tumbler-short-horizon over 100 s" in html
    assert (folder / "plots" / "tumbler-short-horizon-horizon.png").read_bytes()[:4] == b"\x89PNG"
    assert doc["passed"] == (code == 0) and PARTS == 2
    assert [s for s in doc["scenarios"] if not s["passed"]] == [] or code == 1


def test_without_the_flag_there_is_no_horizon_section(tmp_path):
    scenario = _short_horizon(tmp_path)
    out = tmp_path / "reports"
    assert main(["report", "--quick", "--workers", "1", "--out", str(out), str(scenario)]) == 0
    (folder,) = [p for p in out.iterdir() if p.is_dir() and not p.is_symlink()]
    assert "horizons" not in json.loads((folder / "results.json").read_text())
    assert "id='horizons'" not in (folder / "index.html").read_text()


def test_a_horizon_whose_reference_is_refused_fails_the_section_saying_why(tmp_path):
    """RAX-1 with its momentum wheel over six hours: its reference disagrees with itself (3.6e-5 rad at half the
    tolerance, over the 1e-8 rad allowed), so the section says the horizon was not run and why, and fails the report
    (a bundled horizon must run)."""
    text = (BUNDLED_MODELS / "scenarios" / "rax1-momentum-bias.toml").read_text()
    text = text.replace('model = "../rax1_wheel.xml"', f'model = "{BUNDLED_MODELS / "rax1_wheel.xml"}"')
    text += "\n[horizon]\nduration = 21600.0\nsteps = [0.5]\n"
    path = tmp_path / "bias-6h.toml"
    path.write_text(text.replace('name = "rax1-momentum-bias"', 'name = "bias-6h"'))
    from xcheck.report.horizons import horizon_section, start_horizons
    from xcheck.scenario import load_scenario

    section = horizon_section(start_horizons([load_scenario(path)], None))
    assert not section.passed
    assert section.results["horizons"]["refused"][0]["scenario"] == "bias-6h"
    assert "differs from itself at half the tolerance" in section.results["horizons"]["refused"][0]["why"]
