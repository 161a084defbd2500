"""The study store (issue 61, :mod:`xcheck.study.store`): a study asked twice in the processes of one test suite is
run once. Truth: a study run afresh, number for number; and the work itself, counted (``map_tasks`` called or not)."""

from __future__ import annotations

import dataclasses

import pytest

import xcheck.study as study
from xcheck.scenario import resolve_scenario
from xcheck.study.store import ENV

METHODS = ["lie-rkmk4", "formulation-2"]


@pytest.fixture
def counted(monkeypatch):
    """How many studies ran their tasks (``map_tasks`` called), in this process."""
    calls = []
    real = study.map_tasks

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(study, "map_tasks", counting)
    return calls


def _errors(st):
    return {m: [r.attitude_error for r in res.runs] for m, res in st.methods.items()}


def test_a_study_asked_again_is_read_and_is_the_same_study(tmp_path, monkeypatch, counted):
    monkeypatch.setenv(ENV, str(tmp_path))
    sc = resolve_scenario("gyroscope-nonsingular")
    first = study.run_study(sc, methods=METHODS, quick=True, workers=1, timing=False)
    assert len(counted) == 1 and len(list(tmp_path.glob("*.pickle"))) == 1
    again = study.run_study(resolve_scenario("gyroscope-nonsingular"), methods=METHODS, quick=True, workers=1,
                            timing=False)
    assert len(counted) == 1  # read, not run
    assert _errors(again) == _errors(first) and again.outcome == first.outcome
    monkeypatch.delenv(ENV)
    fresh = study.run_study(resolve_scenario("gyroscope-nonsingular"), methods=METHODS, quick=True, workers=1,
                            timing=False)
    assert len(counted) == 2 and _errors(fresh) == _errors(first)  # the truth: run afresh, the same numbers


@pytest.mark.parametrize("change", ["steps", "duration", "methods", "full", "timing"])
def test_a_different_ask_is_run(tmp_path, monkeypatch, counted, change):
    """Another step, duration, method list, a full study in place of a quick one, or wall times asked for where the
    kept study has none: each is run, not read."""
    monkeypatch.setenv(ENV, str(tmp_path))
    sc = resolve_scenario("gyroscope-nonsingular")
    study.run_study(sc, methods=METHODS, quick=True, workers=1, timing=False)
    ask = dict(methods=METHODS, quick=True, workers=1, timing=False)
    other = resolve_scenario("gyroscope-nonsingular")
    if change == "steps":
        ask["steps"] = [0.0625, 0.03125]
    elif change == "duration":
        other = dataclasses.replace(other, duration=other.duration / 2)
    elif change == "methods":
        ask["methods"] = METHODS[:1]
    elif change == "full":
        ask["quick"] = False
        other = dataclasses.replace(other, steps=(0.125, 0.0625, 0.03125))
    else:
        ask["timing"] = True
    study.run_study(other, **ask)
    assert len(counted) == 2


def test_without_a_store_nothing_is_kept_or_read(tmp_path, monkeypatch, counted):
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    for _ in range(2):
        study.run_study(resolve_scenario("gyroscope-nonsingular"), methods=METHODS, quick=True, workers=1,
                        timing=False)
    assert len(counted) == 2 and list(tmp_path.iterdir()) == []


def test_a_reports_studies_are_kept_and_serve_the_same_ask(tmp_path, monkeypatch, counted):
    """``run_studies`` (the report's, its runs timed) keeps each study; ``run_study`` of the same scenario, quick,
    timed or not, reads it: the bundled scenarios' pytest items and the suite's quick report share their studies so."""
    monkeypatch.setenv(ENV, str(tmp_path))
    sc = dataclasses.replace(resolve_scenario("gyroscope-nonsingular"), methods=tuple(METHODS))
    [report] = study.run_studies([sc], quick=True, workers=1)
    assert len(counted) == 1 and len(list(tmp_path.glob("*.pickle"))) == 1
    for timing in (False, True):
        item = study.run_study(dataclasses.replace(resolve_scenario("gyroscope-nonsingular"), methods=tuple(METHODS)),
                               quick=True, workers=1, timing=timing)
        assert len(counted) == 1 and _errors(item) == _errors(report)
