"""A study's trajectory files (issue 39): each ``[[trajectory]]`` of the scenario scored against the study's own
reference (:func:`xcheck.scoring.score.score_file`) in the process that assembles the study, and its check made:
``file`` (its largest attitude error within its tolerance) or, for a file the scenario expects to fail,
``expected-failure``."""

from __future__ import annotations

from ..results import Check
from ..scoring.score import read_file, score_file

__all__ = ["score_trajectories", "read_trajectories"]


def read_trajectories(scenarios) -> None:
    """Read and check every ``[[trajectory]]`` file of ``scenarios`` before their studies run (issue 64: a malformed
    file was refused after 7-15 s of work, a three-scenario report lost whole): a
    :class:`~xcheck.scoring.reader.TrajectoryFileError` naming the file, line and column (exit 2). The files read
    are kept for their scoring (:func:`~xcheck.scoring.score.read_file`)."""
    for sc in scenarios:
        for conv in sc.trajectories or ():
            read_file(conv, duration=sc.duration, earth=sc.earth)


def score_trajectories(st):
    """``st`` (a :class:`~xcheck.study.StudyResult`) with its scenario's files scored and their checks added."""
    sc = st.scenario
    if not sc.trajectories:
        return st
    from .context import run_context, scenario_reference

    ctx = run_context(sc)
    reference = scenario_reference(sc)
    expected = sc.checks["expected_to_fail"]
    for conv in sc.trajectories:
        score = score_file(conv, reference.at, inertia=ctx.inertia, duration=sc.duration, earth=sc.earth,
                           tolerance=sc.checks["final_error"], torque_free=ctx.torque is None)
        st.files[conv.name] = score
        if conv.name in expected:
            st.checks.append(Check("expected-failure", not score.passed, conv.name, value=score.max_attitude_error,
                                   limit=score.tolerance, note=score.sentence() if not score.passed
                                   else "expected to fail, but its error is within its tolerance"))
        else:
            st.checks.append(Check("file", score.passed, conv.name, value=score.max_attitude_error,
                                   limit=score.tolerance, note=score.sentence()))
    return st
