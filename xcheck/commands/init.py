"""``xcheck init``: the scenario file an MJCF model stands for, every key present and commented, to edit."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..base.errors import UsageError, UserError
from . import Context, Outcome
from .arguments import duration_arg


@dataclass
class InitOutcome(Outcome):
    path: Path
    assumptions: list


def init(*, model: str, keyframe: str | None, out: str | None, force: bool, ctx: Context,
         duration: str | None = None) -> InitOutcome:
    """Write the scenario of ``model`` (``MODEL.xml`` or ``MODEL.xml#KEYFRAME``) to ``out`` (default
    ``./xcheck_<model>.toml``, which pytest collects through xcheck's plugin)."""
    from ..base.files import check_output_file, write_text_atomic
    from ..paths import input_problem
    from ..model_scenario import model_scenario_text
    from ..scenario import foreign_model, is_model_arg, split_model_arg

    foreign = foreign_model(model)
    if foreign:
        raise UsageError(f"MODEL: {foreign}")
    if not is_model_arg(model):
        raise UsageError(f"MODEL: expected an MJCF file (.xml, optionally #KEYFRAME), got {model!r}")
    path, key = split_model_arg(model)
    key = keyframe if keyframe is not None else key
    problem = input_problem(path, "MJCF file")
    if problem:
        raise UsageError(f"MODEL: {problem}")
    target = Path(out) if out else Path(f"xcheck_{path.stem}.toml")
    check_output_file(target, "--out", suffixes=(".toml",))
    if target.exists() and not force:
        raise UsageError(f"--out: {target} exists; give another --out, or --force to replace it")
    relative = os.path.relpath(path.resolve(), target.resolve().parent)
    seconds = duration_arg(duration) if duration is not None else None
    try:
        text, assumptions = model_scenario_text(path, key, model_ref=Path(relative).as_posix(), duration=seconds)
    except UserError as exc:
        if seconds is None:
            raise
        model_scenario_text(path, key)  # the model's own error, where it has one
        raise UsageError(f"--duration {duration}: {exc}") from None
    write_text_atomic(target, text)
    ctx.written.append(target)
    ctx.say(f"wrote {target}: the scenario xcheck assumes for {path.name}; edit it, then: xcheck report {target}")
    for a in assumptions:
        ctx.say(f"  - {a}")
    return InitOutcome("PASSED", target, list(assumptions))
