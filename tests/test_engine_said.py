"""Issue 62: an engine's own warnings are caught into the run's notes, not printed raw. DART writes its warnings
from C++ to the standard error in ANSI colours (``Warning [BodyNode.cpp:633] [BodyNode] A negative or zero mass
...``); xcheck.base.captured catches what comes to file descriptor 2 while an engine runs. Truth: DART's own warning,
made by giving a throwaway body zero mass, inside a real DART run."""

from __future__ import annotations

import dataclasses

import pytest

from xcheck.base.captured import clean_lines, engine_said


def _zero_mass_warning():
    """DART's warning of a zero mass (a throwaway skeleton of its own)."""
    dartpy = pytest.importorskip("dartpy")
    skeleton = dartpy.dynamics.Skeleton("throwaway")
    _, body = skeleton.createFreeJointAndBodyNodePair()
    body.setMass(0.0)


def test_what_dart_writes_to_the_standard_error_is_caught_not_shown(capfd):
    lines = []
    with engine_said(lines):
        _zero_mass_warning()
    out, err = capfd.readouterr()
    assert "BodyNode" not in out + err  # nothing reached the terminal
    assert len(lines) == 1 and lines[0].startswith("Warning [BodyNode.cpp:") and "zero mass [0]" in lines[0]
    assert "\x1b" not in lines[0]  # its colours removed
    assert clean_lines("\x1b[1;33mA\x1b[0m x\n\nA x\nB") == ["A x", "B"]  # each line once, in order


def test_an_engines_python_writes_are_caught_too():
    """In a process of its own (where sys.stderr is file descriptor 2, as in a user's run): a write left in Python's
    buffer (no newline) is caught with the C++ ones, and the process' standard error stays empty."""
    import subprocess
    import sys

    code = ("import sys\nfrom xcheck.base.captured import engine_said\nlines = []\nwith engine_said(lines):\n"
            "    sys.stderr.write('an engine said this')\nprint(lines)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert proc.stdout.strip() == "['an engine said this']"


def test_a_runs_engine_warning_is_in_its_note_and_the_studys_lines(capfd, monkeypatch):
    """A DART run during which DART warns: the run's note says "DART said: Warning [BodyNode.cpp:...", the study's
    lines name the method and the runs, and nothing reached the terminal."""
    pytest.importorskip("dartpy")
    from xcheck import runners
    from xcheck.scenario import resolve_scenario
    from xcheck.study import engine_said_lines, run_study

    name = "dart-semi-implicit-euler"
    runner = runners.RUNNERS[name]

    def warned(ctx, dt):
        _zero_mass_warning()
        return runner.run(ctx, dt)

    monkeypatch.setitem(runners.RUNNERS, name, dataclasses.replace(runner, run=warned))
    st = run_study(resolve_scenario("gyroscope-nonsingular"), methods=[name], quick=True, workers=1, timing=False)
    out, err = capfd.readouterr()
    assert "BodyNode" not in out + err
    notes = [r.message for r in st.methods[name].runs]
    assert all(n.startswith("DART said: Warning [BodyNode.cpp:") for n in notes), notes
    lines = engine_said_lines(st)
    assert len(lines) == 1 and lines[0].startswith(f"{name}, in every run: DART said: Warning [BodyNode.cpp:"), lines
