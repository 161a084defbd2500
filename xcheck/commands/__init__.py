"""The workflow layer: one function per command, under the command line and above every room it uses.

Each command is a function of typed keyword arguments (named as the command line's options are) and a
:class:`Context` (where its lines go, its progress bar, what it has written), returning an :class:`Outcome`
whose ``outcome`` is the verdict (``PASSED``, ``FAILED`` or ``INCONCLUSIVE``). A refusal raises a
:class:`xcheck.base.errors.UserError` before any work. :func:`call` runs one by the command line's name; the command
line itself (:mod:`xcheck.cli`) is argparse, printing and exit codes.

    report, nightly, bench        reports.py     the report, the nightly (report + history), the benchmark
    converge, run, list           studies.py     one study, one run, what is bundled
    horizon                       horizon.py     one scenario over a long duration: how the errors grow
    sweep                         sweeps.py      a model-swap sweep
    league, releases, mjx         tables.py      the docs' tables: the boxes league, MuJoCo's releases, MJX
    init                          init.py        the scenario file an MJCF model stands for
    determine                     determine.py   attitude determination: seed 002's tables, a scenario's study
"""

from __future__ import annotations

import importlib
import inspect
import sys
from dataclasses import dataclass, field
from typing import Callable

#: command -> (module of this package, function)
COMMANDS = {"list": ("studies", "list_all"), "converge": ("studies", "converge"), "run": ("studies", "run_one"),
            "report": ("reports", "report"), "nightly": ("reports", "nightly"), "bench": ("reports", "bench"),
            "sweep": ("sweeps", "sweep"), "league": ("tables", "league"), "releases": ("tables", "releases"),
            "mjx": ("tables", "mjx"), "init": ("init", "init"), "determine": ("determine", "determine"),
            "score": ("score", "score"), "horizon": ("horizon", "horizon")}


def _stderr(text: str) -> None:
    print(text, file=sys.stderr)


def _no_progress():
    return lambda done, total, label="": None


@dataclass
class Context:
    """Where a command's lines go (``say``: its results, ``note``: remarks beside them), its progress bar (a factory:
    one bar per phase), the files and folders it has completed (``written``: an interrupt after one says so) and
    when the process started (``started``, for ``--timings``)."""

    say: Callable[[str], None] = print
    note: Callable[[str], None] = _stderr
    progress: Callable = _no_progress
    written: list = field(default_factory=list)
    started: float | None = None


@dataclass
class Outcome:
    """A command's verdict: ``PASSED``, ``FAILED`` or ``INCONCLUSIVE`` (:data:`xcheck.results.OUTCOMES`)."""

    outcome: str


def call(command: str, options, ctx: Context) -> Outcome:
    """Run ``command`` with the attributes of ``options`` (an argparse namespace) its function takes."""
    from .arguments import engine_variables, workers_arg

    module, name = COMMANDS[command]
    fn = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    named = [k for k, p in inspect.signature(fn).parameters.items()
             if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and k != "ctx"]
    kwargs = {k: getattr(options, k) for k in named}
    engine_variables()
    if "workers" in kwargs:
        kwargs["workers"] = workers_arg(kwargs["workers"], ctx)
    return fn(**kwargs, ctx=ctx)
