"""Issue 62: what each engine was given. A line per engine on how it built the body (its joints, where the wheels
went, what was switched off), and the body itself in numbers, in the study's JSON, the terminal and the report.
Truth: the MJCF's own numbers (MuJoCo's compiled model) and the bodies the scenarios name."""

from __future__ import annotations

import warnings

import pytest

from xcheck.engines import ENGINES
from xcheck.engines.built import BUILT


def test_every_engine_says_what_it_was_given_for_each_kind_of_body():
    assert set(ENGINES) | {"xcheck"} <= set(BUILT)
    assert all(set(kinds) == {"free", "top", "gyrostat"} and all(kinds.values()) for kinds in BUILT.values())


def _study(name, methods):
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run_study(resolve_scenario(name), methods=methods, quick=True, workers=1, timing=False)


def test_a_top_a_gyrostat_and_a_free_body_say_what_each_engine_was_given():
    """The heavy top: its mass and centre of mass are MuJoCo's compiled model's (subtree mass, the centre from the
    pivot); MuJoCo is given the MJCF as written, ours the inertia about the pivot. The three-wheel tumbler is a
    gyrostat of three wheels; the gyroscope a free body. The terminal's block and the report's paragraph say them."""
    mujoco = pytest.importorskip("mujoco")
    from xcheck.commands.studies import built_block
    from xcheck.paths import BUNDLED_MODELS
    from xcheck.report.document import to_markdown
    from xcheck.report.render import _built_blocks

    top = _study("heavy-top", ["lie-rkmk4", "mujoco-rk4"])
    m = mujoco.MjModel.from_xml_path(str(BUNDLED_MODELS / "heavy_top.xml"))
    mass = float(m.body_subtreemass[1])
    built = top.data["built"]
    assert built["body"].startswith(f"a top: mass {mass:.6g} kg, centre of mass [0, 0, 0.0100495] m from the pivot, "
                                    "gravity [0, 0, -9.81] m/s^2")
    assert set(built["engines"]) == {"xcheck", "mujoco"}
    assert built["engines"]["mujoco"].startswith("the MJCF as written: the body on its ball joint")
    assert "inertia about the pivot" in built["engines"]["xcheck"]
    lines = built_block(top)
    assert lines[0] == f"  what each engine was given ({built['body']}):"
    assert lines[2].startswith("    MuJoCo: the MJCF as written")
    assert "What each engine was given" in to_markdown(_built_blocks(top))
    assert _study("tumbler-three-wheels", ["lie-rkmk4"]).data["built"]["body"] == "a gyrostat: a bus and 3 wheels"
    assert _study("gyroscope-nonsingular", ["lie-rkmk4"]).data["built"]["body"] == "a free body"
