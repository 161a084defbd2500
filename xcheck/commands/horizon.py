"""``xcheck horizon``: one scenario over a long duration, each method at a few steps (issue 41,
:mod:`xcheck.study.horizon`): how its attitude error and energy grow, and how long it stays within 1e-6 and 1e-3 rad."""

from __future__ import annotations

import dataclasses

from ..base.errors import UsageError
from . import Context, Outcome
from .arguments import duration_arg, methods_arg, steps_arg


def _duration(text: str | None, scenario) -> float:
    """``--duration`` (:func:`~xcheck.commands.arguments.duration_arg`, every command's rule); default the scenario's
    ``[horizon]`` duration, else 100 times its own."""
    if text is None:
        from ..study.horizon import default_duration

        return default_duration(scenario)
    return duration_arg(text)


def _steps(text: str | None, scenario, duration: float) -> list[float]:
    """``--steps`` over the horizon's ``duration`` (:func:`~xcheck.commands.arguments.steps_arg`); default the
    ``[horizon]`` steps, else the scenario's coarsest quick steps (:func:`~xcheck.study.horizon.default_steps`)."""
    if text is not None:
        return steps_arg(text, dataclasses.replace(scenario, duration=duration))
    from ..scenario import check_steps
    from ..study.horizon import default_steps

    steps = default_steps(scenario, duration)
    try:  # the rule --steps and a [horizon] table are held to, on the default steps over this duration (issue 58)
        return list(check_steps(steps, duration))
    except ValueError as exc:
        raise UsageError(f"--duration: {exc} (scenario {scenario.name}, the horizon's steps "
                         f"{', '.join(f'{s:g}' for s in steps)} s)") from None


def horizon(*, scenario: str, duration: str | None, steps: str | None, methods: str | None, json: str | None,
            out: str | None = None, workers: int | None = None, ctx: Context) -> Outcome:
    from ..base.files import check_output_dir, check_output_file, write_json_atomic
    from ..scenario import resolve_scenario
    from ..study.horizon import THRESHOLDS, momentum_heading, run_horizon, within_text

    sc = resolve_scenario(scenario)
    T = _duration(duration, sc)
    dts = _steps(steps, sc, T)
    chosen = methods_arg(methods) if methods is not None else None
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    if out:
        check_output_dir(out, "--out")
    from ..reference import ReferenceFailure

    if workers is not None and workers < 1:
        raise UsageError(f"--workers: expected 1 or more processes, got {workers}")
    import os
    from contextlib import nullcontext

    from ..base.pool import worker_pool
    from ..study.executor import worker_modules

    two = (workers or min(2, os.cpu_count() or 1)) >= 2  # the runs shared by this process and one worker
    try:
        with worker_pool(1, warm=worker_modules(figures=False)) if two else nullcontext() as pool:
            res = run_horizon(sc, duration=T, steps=dts, methods=chosen, progress=ctx.progress(), pool=pool)
    except ReferenceFailure as exc:
        raise UsageError(f"--duration: {exc}; a shorter duration, or a scenario with a closed form") from None
    ctx.say(f"\n{sc.name} over {T:g} s ({sc.reference} reference): attitude error ∝ t^p, the invariants' largest "
            "changes (the energy's and |L|'s relative, + gained, - damped; a top's L·ĝ about the vertical; the angle "
            "L's direction turned) with their laws, and how long each stays within 1e-6 and 1e-3 rad")
    ctx.say(f"  reference: {res.reference_note}")
    width = max([22, *(len(line.method) for line in res.lines)])
    heading = momentum_heading([line.to_json() for line in res.lines])
    ctx.say(f"  {'method':{width}s} {'step [s]':>10s} {'error at T':>11s} {'p':>6s}  {'energy':<28s} {heading:<28s} "
            f"{'L direction':<30s} " + " ".join(f"{'within ' + format(b, 'g'):>13s}" for b in THRESHOLDS))
    for line in res.lines:
        if line.status != "ok":
            ctx.say(f"  {line.method:{width}s} {line.dt:>10.6g} failed: {line.message}")
            continue
        p = "—" if line.growth is None else f"{line.growth:.2f}"
        energy, size, turn = line.change_texts()
        within = " ".join(f"{within_text(line.within[b], T):>13s}" for b in THRESHOLDS)
        ctx.say(f"  {line.method:{width}s} {line.dt:>10.6g} {line.final_error:>11.3g} {p:>6s}  {energy:<28s} "
                f"{size:<28s} {turn:<30s} {within}")
    for line in res.left_out:
        ctx.say(f"  {line}")
    if json:
        write_json_atomic(json, res.to_json())
        ctx.written.append(json)
    if out:
        from pathlib import Path

        from ..report.plots import horizon_figure, save_figure

        path = Path(out) / f"{sc.name}-horizon.png"
        save_figure(horizon_figure(res.to_json()), path)
        ctx.written.append(str(path))
        ctx.say(f"figure: {path}")
    return Outcome("PASSED")

