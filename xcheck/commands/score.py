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
    else as ``declaration`` (or the sidecar ``FILE.toml``) declares, else as a ``[[trajectory]]`` of the scenario
    whose columns its header has declares (:func:`_by_header`), else as xcheck's own CSV."""
    from pathlib import Path

    from ..base.files import check_output_file, write_json_atomic
    from ..scenario import load_declaration, resolve_scenario, sidecar_of
    from ..study.context import run_context, scenario_reference
    from ..scoring.score import score_file

    sc = resolve_scenario(scenario)
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    path = Path(file)
    conv = next((c for c in sc.trajectories if path.exists() and c.file == path.resolve()), None)
    declared_by = None
    if conv is None and not declaration and not sidecar_of(path).is_file():
        conv, declared_by = _by_header(path, sc)
    if conv is None or declaration:
        conv = load_declaration(path, declaration=declaration, earth=sc.earth)
    ctx_run = run_context(sc)
    s = score_file(conv, scenario_reference(sc).at, inertia=ctx_run.inertia, duration=sc.duration, earth=sc.earth,
                   tolerance=conv.tolerance or sc.checks["final_error"], torque_free=ctx_run.torque is None)
    ctx.say(f"\n{conv.name} against {sc.name} (reference: {scenario_reference(sc).used}): {s.outcome}")
    if declared_by:
        ctx.say(f"  declared by: {declared_by}")
    ctx.say(f"  read as: {s.convention}")
    for line in file_lines([s]):
        ctx.say(line)
    if json:
        write_json_atomic(json, {"schema": "xcheck.score/1", "scenario": sc.name, **s.to_json(),
                                 **({"declared_by": declared_by} if declared_by else {})})
    return ScoreOutcome(s.outcome, s)


def _by_header(path, sc):
    """The scenario's ``[[trajectory]]`` declaration that reads the file ``path`` by its header (issue 63: a file
    from the same simulators, under another name, has the very columns the scenario declares), as ``(convention,
    what to say)``; ``(None, None)`` where none does. Declarations that match but read the file differently are
    refused by name: which one applies is the user's to say, with ``--declaration``."""
    from dataclasses import replace

    from ..scenario import ScenarioError
    from ..scoring.convention import declared_layout, layout_of
    from ..scoring.reader import read_header

    if not path.is_file():
        return None, None  # the reader refuses it, naming the file
    matches = declared_layout(read_header(path), sc.trajectories)
    if not matches:
        return None, None
    if len({layout_of(c) for c in matches}) > 1:
        names = ", ".join(repr(c.name) for c in matches)
        raise ScenarioError(f"{path}: its header has the columns of {len(matches)} of {sc.name}'s [[trajectory]] "
                            f"tables ({names}), which read them differently; say which with --declaration FILE.toml")
    first = matches[0]
    others = f", as {len(matches) - 1} more of its tables do" if len(matches) > 1 else ""
    said = (f"{sc.name}'s [[trajectory]] {first.name!r}, tolerance included: the file's header has the columns it "
            f"declares{others}")
    return replace(first, file=path.resolve(), name=path.stem, source=""), said
