"""Issue 62: what to use instead. Per engine, the cheapest of its integrators at the largest studied step that keeps
the tolerance over the run (there and at every finer step), in a line a user can copy. Truth: the advised
integrator run again, outside the study, at the advised step, against the exact reference (the torque-free closed
form): its largest attitude error over the run is within the tolerance."""

from __future__ import annotations

import re

import numpy as np
import pytest

from xcheck.results import MethodResult, Run
from xcheck.study.advice import advised_run


def _method(errors):
    runs = [Run(dt=dt, max_attitude_error=e, status="ok" if e is not None else "failed", wall_time=1e-3 / dt)
            for dt, e in errors]
    return MethodResult(name="m", engine="xcheck", expected_order=4, runs=runs)


def test_the_advised_step_keeps_the_tolerance_there_and_at_every_finer_step():
    """Coarse to fine 0.5 (1e-3), 0.25 (1e-7, lucky), 0.125 (1e-5), 0.0625 (1e-8), 0.03125 (1e-9): at 1e-6 rad the
    advice is 0.0625 s, not the lucky 0.25; a failed finest run leaves nothing to advise."""
    m = _method([(0.5, 1e-3), (0.25, 1e-7), (0.125, 1e-5), (0.0625, 1e-8), (0.03125, 1e-9)])
    assert advised_run(m, 1e-6).dt == 0.0625
    assert advised_run(m, 1e-2).dt == 0.5
    assert advised_run(m, 1e-10) is None
    assert advised_run(_method([(0.5, 1e-8), (0.25, None)]), 1e-6) is None


@pytest.fixture(scope="module")
def study():
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study

    return run_study(resolve_scenario("gyroscope-nonsingular"), quick=True, workers=1,
                     methods=["lie-rkmk4", "formulation-2", "mujoco-rk4", "mujoco-euler", "mujoco-implicitfast"])


def test_mujocos_advice_run_again_keeps_the_tolerance(study):
    """The gyroscope (10 s, quick steps 1/64 ... 1/1024 s, tolerance 1e-6 rad): MuJoCo's cheapest within 1e-6 rad is
    RK4 (its first-order integrators are 1e-3 rad off at 1/1024 s); the MJCF line names it, and MuJoCo run again at
    that step is within 1e-6 rad of the closed form over the whole run."""
    from xcheck.commands.studies import advice_block
    from xcheck.engines.mujoco import simulate
    from xcheck.reference import exact_reference
    from xcheck.rotations import attitude_error

    sc = study.scenario
    mujoco = next(a for a in study.data["advice"] if a["engine"] == "mujoco")
    assert mujoco["method"] == "mujoco-rk4" and mujoco["tolerance"] == 1e-6 and mujoco["duration"] == sc.duration
    lines = advice_block(study)
    line = next(x for x in lines if x.strip().startswith("MuJoCo, for 1e-06 rad over 10 s: "))
    step = float(re.search(r'<option integrator="RK4" timestep="([0-9.e-]+)"/>', line).group(1))
    assert step == mujoco["dt"]
    traj = simulate(sc.model, integrator="rk4", q0=sc.q0, omega0=sc.omega0, dt=step, duration=sc.duration)
    from xcheck.assembly import context_of

    ctx = context_of(sc)
    q_ref, _ = exact_reference(ctx.inertia, ctx.q0, ctx.omega0, traj.t)
    worst = float(np.max(attitude_error(traj.q, q_ref)))
    assert worst <= 1e-6, worst
    assert worst == pytest.approx(mujoco["error"], rel=1e-9)  # the study's own number, measured again
    ours = next(a for a in study.data["advice"] if a["engine"] == "xcheck")
    assert ours["method"] in ("lie-rkmk4", "formulation-2") and ours["error"] <= 1e-6
    assert any(f"xcheck run gyroscope-nonsingular --method {ours['method']} --dt {ours['dt']!r}" in x for x in lines)


def test_an_engine_whose_steps_never_keep_it_says_so(study):
    """With a tolerance of 1e-15 rad (below round-off) no step of MuJoCo's keeps it: the line says so and gives its
    least error."""
    import dataclasses

    from xcheck.study.advice import advice, advice_lines

    sc = dataclasses.replace(study.scenario, checks={**study.scenario.checks, "tolerance": 1e-15})
    tight = advice(sc, study.methods)
    mujoco = next(a for a in tight if a["engine"] == "mujoco")
    best = min(r.max_attitude_error for n in ("mujoco-rk4", "mujoco-euler", "mujoco-implicitfast")
               for r in study.methods[n].runs if r.ok)
    assert mujoco["method"] is None and mujoco["best"]["error"] == best
    text = advice_lines(dataclasses.replace(study, advice=tight))
    assert any(x.startswith("MuJoCo, for 1e-15 rad over 10 s: no studied step keeps it; its least error is")
               for x in text), text
