"""``xcheck determine``: seed 002's tables reproduced (``--seed002``), or a scenario's attitude-determination
study alone."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..base.errors import UsageError
from . import Context, Outcome


@dataclass
class DetermineOutcome(Outcome):
    data: dict


def determine(*, scenario: str | None, seed002: bool, json: str | None, out: str | None,
              ctx: Context) -> DetermineOutcome:
    """Seed 002's tables beside xcheck's, or the ``[determination]`` study of ``scenario`` (its defaults where the
    scenario has none), its JSON and its report folder."""
    from ..base.files import check_output_dir, check_output_file

    if seed002 == bool(scenario):
        raise UsageError("give a SCENARIO (its [determination] study) or --seed002 (the seed's tables), one of them")
    if seed002:
        from ..determination.seed002 import report_lines, reproduce

        rep = reproduce()
        ctx.say("\n".join(report_lines(rep)))
        return DetermineOutcome("PASSED" if rep["passed"] else "FAILED", rep)
    from ..determination.sensors import DEFAULT_SPEC
    from ..determination.study import run_determination, summary_lines
    from ..scenario import resolve_scenario

    sc = resolve_scenario(scenario)
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    if out:
        check_output_dir(out, "--out")
    if sc.determination is None:
        ctx.note(f"{sc.name} has no [determination] table: the defaults (see the README)")
    data, series = run_determination(sc, sc.determination or DEFAULT_SPEC)
    for line in summary_lines(data):
        ctx.say(line)
    if json:
        from ..base.files import write_json_atomic

        write_json_atomic(Path(json), data)
    if out:
        from ..report.determination import draw_determination, write_determination

        folder = write_determination(data, draw_determination(data, series), out)
        ctx.written.append(folder)
        ctx.say(f"report: {folder}/index.html")
    return DetermineOutcome("PASSED" if data["passed"] else "FAILED", data)
