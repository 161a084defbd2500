"""``xcheck score FILE --scenario S``: one trajectory file, written by any simulator, scored against a scenario's
reference (issue 39), with the convention detective's findings; the same numbers as the scenario's own
``[[trajectory]]`` row for that file."""

from __future__ import annotations

from dataclasses import dataclass

from . import Context, Outcome

__all__ = ["score", "file_lines"]


@dataclass
class ScoreOutcome(Outcome):
    score: object  # xcheck.scoring.score.FileScore


def file_lines(scores) -> list[str]:
    """Trajectory files as the terminal shows them: one line each, then each one's sentence where it failed or the
    detective found something."""
    if not scores:
        return []
    lines = [f"  {'trajectory file':22s} {'attitude [rad]':>14s} {'rate [rad/s]':>12s} {'growth':>7s}  outcome"]
    for s in scores:
        rate = "—" if s.max_rate_error is None else format(s.max_rate_error, ".2e")
        growth = "—" if s.growth is None else f"t^{s.growth:.2f}"
        lines.append(f"  {s.name:22s} {s.max_attitude_error:>14.2e} {rate:>12s} {growth:>7s}  {s.outcome}")
    lines += [f"  {s.sentence()}" for s in scores if not s.passed or s.findings]
    lines += [f"  note ({s.name}): {n}" for s in scores for n in s.notes]
    return lines


def score(*, file: str, scenario: str, declaration: str | None, json: str | None, ctx: Context) -> ScoreOutcome:
    """Score ``file`` against ``scenario``'s reference: read as the scenario's ``[[trajectory]]`` for it declares,
    else as ``declaration`` (or the sidecar ``FILE.toml``) declares, else as xcheck's own CSV."""
    from pathlib import Path

    from ..base.files import check_output_file, write_json_atomic
    from ..scenario import load_declaration, resolve_scenario
    from ..study.context import run_context, scenario_reference
    from ..scoring.score import score_file

    sc = resolve_scenario(scenario)
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    path = Path(file)
    conv = next((c for c in sc.trajectories if path.exists() and c.file == path.resolve()), None)
    if conv is None or declaration:
        conv = load_declaration(path, declaration=declaration, earth=sc.earth)
    ctx_run = run_context(sc)
    s = score_file(conv, scenario_reference(sc).at, inertia=ctx_run.inertia, duration=sc.duration, earth=sc.earth,
                   tolerance=conv.tolerance or sc.checks["final_error"], torque_free=ctx_run.torque is None)
    ctx.say(f"\n{conv.name} against {sc.name} (reference: {scenario_reference(sc).used}): {s.outcome}")
    ctx.say(f"  read as: {s.convention}")
    for line in file_lines([s]):
        ctx.say(line)
    if json:
        write_json_atomic(json, {"schema": "xcheck.score/1", "scenario": sc.name, **s.to_json()})
    return ScoreOutcome(s.outcome, s)
