"""The command line's values read into typed ones, or a :class:`~xcheck.base.errors.UsageError` naming the option:
comma-separated lists, methods, steps, worker counts, engines to add, MuJoCo releases, the docs commands' outputs."""

from __future__ import annotations

import math

import os

from ..base.errors import UsageError


def csv_list(text: str, kind, name: str) -> list:
    """``"a,b"`` -> ``["a", "b"]`` (``kind`` str), or positive finite steps (``kind`` float); no empty item, none
    twice."""
    items = [x.strip() for x in text.split(",")]
    if not text.strip() or not all(items):
        raise UsageError(f"{name}: expected a comma-separated list (no empty item), got {text!r}")
    if kind is float:
        out = []
        for x in items:
            try:
                v = float(x)
            except ValueError:
                raise UsageError(f"{name}: {x!r} is not a number of seconds") from None
            if not (v > 0 and v == v and v != float("inf")):
                raise UsageError(f"{name}: {x!r} is not a positive finite step")
            out.append(v)
        items = out
    repeated = sorted({str(x) for x in items if items.count(x) > 1})
    if repeated:
        raise UsageError(f"{name}: {', '.join(repeated)} given more than once")
    return items


def methods_arg(text: str) -> list[str]:
    """``--methods``: runner names, each known (an engine's that is not installed says how to get it)."""
    from ..runners import RUNNERS, unknown_method

    methods = csv_list(text, str, "--methods")
    for m in methods:
        if m not in RUNNERS:
            raise UsageError(f"--methods: {unknown_method(m)}")
    return methods


def steps_arg(text: str, scenario) -> list[float]:
    """``--steps`` for ``scenario``: each shorter than its duration, within the machine's memory."""
    from ..scenario import check_steps

    steps = csv_list(text, float, "--steps")
    try:
        return list(check_steps(steps, scenario.duration))
    except ValueError as exc:
        raise UsageError(f"--steps: {exc} (scenario {scenario.name}, duration {scenario.duration:g} s)") from None


def clock_note(runner, dt: float, flag: str) -> str | None:
    """The note of ``runner``'s engine clock on the step ``dt`` (None: taken as given); a refusal naming ``flag``
    for a step the engine's clock cannot take."""
    if runner.clock is None:
        return None
    try:
        return runner.clock(dt)
    except ValueError as exc:
        raise UsageError(f"{flag}: {str(exc).removeprefix('dt: ')} ({runner.name})") from None


def workers_arg(workers: int | None, ctx) -> int | None:
    """``--workers``: positive; more than the CPUs are capped, saying so (1000 made a 2 s job take 107 s)."""
    if workers is None:
        return None
    if workers < 1:
        raise UsageError("--workers: expected a positive number of processes")
    cpus = os.cpu_count() or 1
    if workers > cpus:
        ctx.note(f"note: --workers {workers}: {cpus} worker processes, one per CPU (more would only share them and "
                 "each holds ~55 MB)")
        return cpus
    return workers


def _opt_in(names, what: str) -> None:
    """Each of ``names`` an opt-in engine that is installed, or a refusal naming ``what`` (``--with``, the
    variable)."""
    from ..engines import ENGINES, available

    opt_in = [n for n, e in ENGINES.items() if e.opt_in]
    for name in names:
        if name not in opt_in:
            raise UsageError(f"{what}: {name!r} is not an opt-in engine (expected some of {', '.join(opt_in)}); the "
                             "others run whenever they are installed")
        if not available(name):
            raise UsageError(f"{what}: {name} is not installed here: pip install 'xcheck[{ENGINES[name].extra or name}]'")


def engine_variables() -> None:
    """``$XCHECK_WITH`` and ``$XCHECK_WITHOUT`` as ``--with`` is: names of engines (opt-in ones for the first,
    installed), or a refusal naming the variable (a typo once left MJX out silently)."""
    from ..engines import ENGINES, WITH_VARIABLE, WITHOUT_VARIABLE

    for variable in (WITH_VARIABLE, WITHOUT_VARIABLE):
        text = os.environ.get(variable, "")
        names = [n.strip() for n in text.split(",") if n.strip()]
        if variable == WITH_VARIABLE:
            _opt_in(names, f"${variable}={text!r}")
        for name in names if variable == WITHOUT_VARIABLE else ():
            if name not in ENGINES or name == "mujoco":
                raise UsageError(f"${variable}={text!r}: {name!r} is not an optional engine (expected some of "
                                 f"{', '.join(n for n in ENGINES if n != 'mujoco')})")


def with_engines(text: str | None) -> None:
    """``--with ENGINE[,ENGINE]``: an opt-in engine's methods join every study of this command (and its workers'),
    through ``$XCHECK_WITH``; refused, naming what to install, where the engine is not installed."""
    if not text:
        return
    from ..engines import WITH_VARIABLE

    names = csv_list(text, str, "--with")
    _opt_in(names, "--with")
    os.environ[WITH_VARIABLE] = ",".join(names)


def markdown_and_json(out, json):
    """A docs command's ``--out FILE.md`` (returned as a Path, None when not given) and ``--json PATH``, checked
    before any work."""
    from ..base.files import check_output_file

    md = check_output_file(out, "--out", suffixes=(".md",)) if out else None
    if json:
        check_output_file(json, "--json", suffixes=(".json",))
    return md


def releases_arg(text: str, ctx) -> list[str]:
    """``--mujoco``'s releases, each on the package index (or a note where the index cannot say), before any work."""
    from ..history.matrix import check_on_index, parse_versions

    try:
        versions = parse_versions(text)
        note = check_on_index(versions)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if note:
        ctx.note(note)
    return versions


#: ``--duration``'s units, and how many seconds each is (the longest names first: ``min`` before ``s``).
DURATION_UNITS = {"d": 86400.0, "h": 3600.0, "min": 60.0, "s": 1.0}
DURATION_HELP = "seconds, or with a unit (10, 10 s, 2 min, 1 h, 1 d)"


def duration_arg(text: str) -> float:
    """``--duration`` (every command's, one rule): seconds, or a number and a unit (``10``, ``10 s``, ``2 min``,
    ``1 h``, ``1 d``) -> seconds; a UsageError naming ``--duration`` for zero, a negative, or not a number."""
    import math

    number, factor = str(text).strip(), 1.0
    for unit, scale in DURATION_UNITS.items():
        if number.endswith(unit):
            number, factor = number[: -len(unit)], scale
            break
    try:
        value = float(number) * factor
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise UsageError(f"--duration: expected a positive time, {DURATION_HELP}, got {text!r}")
    return value


def tolerance_arg(text: str) -> float:
    """``--tolerance``: an angle [rad] above 0 and below pi (``1e-6``, ``0.001``); else a UsageError naming it."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        value = math.nan
    if not 0 < value < math.pi:
        raise UsageError(f"--tolerance: expected an attitude error in rad above 0 and below pi (1e-6, 0.001), "
                         f"got {text!r}")
    return value


def user_scenario(name: str, duration: str | None = None, tolerance: str | None = None):
    """The scenario a command runs (:func:`~xcheck.scenario.resolve_scenario`) over the user's ``--duration``, its
    accuracy judged against the user's ``--tolerance`` in place of its ``[checks] tolerance``; a duration the
    scenario's steps do not fit (past the memory a run may take, shorter than every step the file writes) is a
    UsageError naming ``--duration``."""
    import dataclasses

    from ..scenario import ScenarioError, resolve_scenario

    tol = None if tolerance is None else tolerance_arg(tolerance)
    if duration is None:
        sc = resolve_scenario(name)
    else:
        try:  # reading the scenario checks each of its steps over the duration (scenario.check_steps)
            sc = resolve_scenario(name, duration=duration_arg(duration))
        except ScenarioError as exc:
            resolve_scenario(name)  # the scenario's own error, where it has one
            raise UsageError(f"--duration {duration}: {exc}") from None
    return sc if tol is None else dataclasses.replace(sc, checks={**sc.checks, "tolerance": tol})
