"""The ``xcheck`` command line: argparse, the signals, and exit codes; each command's work is a function of
:mod:`xcheck.commands`.

``xcheck list | converge | horizon | run | score | report | nightly | sweep | init | determine | league | releases | mjx | bench``.
Exit codes: 0 when every check passed (and, for ``nightly``, nothing regressed), 1 when a check failed (or something
regressed), 4 when no check failed but the study could not decide, 2 for bad input (a
:class:`xcheck.base.errors.UserError`: the message names the file, key, argument or path), 130 when interrupted
(Ctrl-C), 143 when terminated (SIGTERM), 3 for a bug in xcheck (a one-line message asking to report it; the
traceback with ``XCHECK_DEBUG=1``). Every input and output path is checked before any work starts.
"""

from __future__ import annotations

import argparse
import multiprocessing.util
import os
import sys
import threading
import time
import warnings

from . import __version__
from .commands.arguments import DURATION_HELP
from .base import interrupts
from .base.exits import EXIT_INTERRUPTED, EXIT_TERMINATED, stopped_line
from .base.errors import UsageError, UserError  # noqa: F401 (UsageError: imported from here before issue 38)
from .base.interrupts import (
    Progress,
    Terminated,
    as_interrupt,
    signals_as_interrupts,
    stop_repeating,
)

_STARTED = time.perf_counter()  # when the command line was imported: the baseline of --timings

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_BUG = 0, 1, 2, 3
#: A study that cannot decide (issue 36): its steps show no asymptotic range, its reference is suspect or less
#: certain than a check, or it tests nothing; and no check failed.
EXIT_INCONCLUSIVE = 4
#: The exit code of each outcome (xcheck.results.OUTCOMES).
EXIT_OF = {"PASSED": EXIT_OK, "FAILED": EXIT_CHECK_FAILED, "INCONCLUSIVE": EXIT_INCONCLUSIVE}


#: ``--with``: the opt-in engines (the others run wherever they are installed)
WITH_HELP = ("opt-in engines' methods too, comma-separated: mjx (MJX's RK4, Euler and implicitfast, float32 and x64; "
             "pip install 'xcheck[mjx]'); PyBullet, DART, Drake and EXUDYN run wherever they are installed (pip "
             "install 'xcheck[engines]')")


#: ``--duration`` of the commands that take a scenario or a model (one rule: commands.arguments.duration_arg)
DURATION_OPTION = (f"the run, in place of the scenario's (a model alone's: derived from its motion): {DURATION_HELP}; "
                   "the model's own step stays among the steps")


#: ``--tolerance`` of converge and report: what "accurate" is judged against (commands.arguments.tolerance_arg)
TOLERANCE_OPTION = ("the largest attitude error over the run [rad] a method is accurate within, at your step (the "
                    "model's) or else its finest (default: the scenario's [checks] tolerance, 1e-6)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="xcheck", description="MuJoCo-validated rigid-body attitude cross-checker")
    parser.add_argument("--version", action="version", version=f"xcheck {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("list", help="bundled scenarios and methods")

    p = sub.add_parser("converge", help="one convergence study")
    p.add_argument("scenario", help="a bundled scenario name, a scenario .toml file, or an MJCF model alone "
                                    "(MODEL.xml, MODEL.xml#KEYFRAME)")
    p.add_argument("--methods", help="comma-separated methods (default: the scenario's, or all)")
    p.add_argument("--steps", help="comma-separated steps in seconds (default: the scenario's)")
    p.add_argument("--quick", action="store_true", help="the scenario's quick steps")
    p.add_argument("--duration", help=DURATION_OPTION)
    p.add_argument("--tolerance", help=TOLERANCE_OPTION)
    p.add_argument("--json", metavar="PATH", help="write the results (schema xcheck.convergence/3)")
    p.add_argument("--out", metavar="DIR", help="write the figures into DIR")
    p.add_argument("--workers", type=int, default=None,
                   help="processes for the study, this one included (default: this process, and one worker for "
                        "Basilisk's methods when it is installed)")

    p = sub.add_parser("horizon", help="one scenario over a long duration: how each method's errors grow")
    p.add_argument("scenario", help="a bundled scenario name, a scenario .toml file, or an MJCF model alone "
                                    "(MODEL.xml, MODEL.xml#KEYFRAME)")
    p.add_argument("--duration", help=f"how long: {DURATION_HELP}; default the scenario's [horizon], else 100 times "
                                      "its duration")
    p.add_argument("--steps", help="comma-separated steps in seconds (default: the scenario's [horizon] steps, else "
                                   "its three coarsest quick steps)")
    p.add_argument("--methods", help="comma-separated methods (default: every fixed-step method installed, ours, "
                                     "MuJoCo's and the engines', each engine's within a step budget)")
    p.add_argument("--json", metavar="PATH", help="write the results (schema xcheck.horizon/2)")
    p.add_argument("--out", metavar="DIR", help="write the figure (SCENARIO-horizon.png) into DIR")
    p.add_argument("--workers", type=int, default=None,
                   help="processes, this one included (default: 2 where there are two CPUs or more; 1: here only)")

    p = sub.add_parser("score", help="score a trajectory file of any simulator against a scenario's reference")
    p.add_argument("file", metavar="FILE", help="a CSV of one sample a row (docs/trajectory-files.md)")
    p.add_argument("--scenario", required=True, help="a bundled scenario name, a scenario .toml file, or an MJCF "
                                                     "model alone (MODEL.xml, MODEL.xml#KEYFRAME)")
    p.add_argument("--declaration", metavar="TOML", help="how FILE states its conventions (default: the scenario's "
                                                         "[[trajectory]] for FILE, else FILE.toml, else xcheck's CSV)")
    p.add_argument("--json", metavar="PATH", help="write the score as JSON")

    p = sub.add_parser("run", help="one trajectory")
    p.add_argument("scenario", help="a bundled scenario name, a scenario .toml file, or an MJCF model alone "
                                    "(MODEL.xml, MODEL.xml#KEYFRAME)")
    p.add_argument("--method", required=True)
    p.add_argument("--dt", type=float, required=True, help="step [s] (an adaptive method's output step)")
    p.add_argument("--duration", help=DURATION_OPTION)
    p.add_argument("--rtol", type=float, help="an adaptive method's relative tolerance (default: its own)")
    p.add_argument("--csv", metavar="PATH", help="write the trajectory as CSV")
    p.add_argument("--plot", metavar="PATH", help="write a PNG plot")

    p = sub.add_parser("report", help="the full cross-check report (the main job)")
    p.add_argument("scenarios", nargs="*", help="bundled names, .toml scenario files or MJCF models (MODEL.xml, "
                                                "MODEL.xml#KEYFRAME; default: every bundled scenario)")
    p.add_argument("--out", default="reports", metavar="DIR", help="where reports go (default: ./reports)")
    p.add_argument("--quick", action="store_true", help="fewer steps, for a fast look")
    p.add_argument("--duration", help=DURATION_OPTION)
    p.add_argument("--tolerance", help=TOLERANCE_OPTION)
    p.add_argument("--bench", action="store_true", help="also run the benchmark into the appendix")
    p.add_argument("--timings", action="store_true", help="print where the time went (phases, on stderr)")
    p.add_argument("--trajectories", action="store_true",
                   help="also write every method's finest run as CSV (trajectories/, ~4 MB a scenario)")
    p.add_argument("--horizon", action="store_true",
                   help="also run each scenario's [horizon] (an orbit, an hour, a day: how long each method stays "
                        "within 1e-6 and 1e-3 rad; three or four minutes for the bundled ones)")
    p.add_argument("--with", dest="with_engines", metavar="ENGINE",
                   help=WITH_HELP)
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")

    p = sub.add_parser("nightly", help="the full report, compared with the history and recorded in it")
    p.add_argument("scenarios", nargs="*", help="bundled names, .toml scenario files or MJCF models (MODEL.xml, "
                                                "MODEL.xml#KEYFRAME; default: every bundled scenario)")
    p.add_argument("--out", default="reports", metavar="DIR", help="where reports go (default: ./reports)")
    p.add_argument("--history", metavar="PATH|URL",
                   help="the history: a SQLite file (default: OUT/history.sqlite) or a postgresql:// URL")
    p.add_argument("--baseline", type=int, metavar="RUN_ID",
                   help="compare with this stored run instead of the rolling baseline")
    p.add_argument("--last", type=int, default=7, metavar="N",
                   help="the rolling baseline: the median of the last N runs (default 7)")
    p.add_argument("--keep", type=int, metavar="N", help="keep the newest N report folders, delete older ones")
    p.add_argument("--error-factor", type=float, default=10.0, metavar="F",
                   help="a regression: an attitude error grown more than F times above its study's floor (10)")
    p.add_argument("--order-drop", type=float, default=0.3, metavar="D",
                   help="a regression: an observed order lower by more than D (0.3)")
    p.add_argument("--speed-drop", type=float, default=0.3, metavar="FRACTION",
                   help="a regression: steps per second lower by more than this fraction, same host only "
                        "(0.3; 1 turns speed comparisons off, for a machine too noisy to time on)")
    p.add_argument("--bench", action="store_true", help="also run xcheck bench and record its rows")
    p.add_argument("--mujoco", metavar="VERSIONS",
                   help="comma-separated MuJoCo releases to run the same scenarios against (the version matrix)")
    p.add_argument("--quick", action="store_true", help="quick reports (a series of their own in the history)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")

    p = sub.add_parser("sweep", help="a model-swap sweep: many cross-checks over bodies, fields, states and steps")
    p.add_argument("spec", help="a bundled sweep (xcheck list) or a sweep spec .toml (see docs/sweeps.md)")
    p.add_argument("--out", default=os.path.join("reports", "sweeps"), metavar="DIR",
                   help="where sweeps go: DIR/<spec name>/<time>/ (default: ./reports/sweeps)")
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="worker processes (default: CPU count)")
    p.add_argument("--resume", action="store_true",
                   help="keep the cells an interrupted (or the latest) run of this spec finished; run the rest")
    p.add_argument("--max-cells", type=int, default=None, metavar="N",
                   help="refuse a spec of more cells than this, before building any (default 100,000: "
                        "xcheck.sweep.spec.MAX_CELLS)")
    p.add_argument("--executor", choices=("local", "dask"), default="local",
                   help="local processes, or a Dask distributed cluster (pip install 'xcheck[distributed]')")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="with --executor dask: the scheduler (tcp://host:8786); default a LocalCluster of --jobs")

    p = sub.add_parser("init", help="write the scenario file an MJCF model stands for (every key, commented)")
    p.add_argument("model", metavar="MODEL", help="an MJCF file (MODEL.xml, or MODEL.xml#KEYFRAME)")
    p.add_argument("--keyframe", metavar="NAME", help="the keyframe that holds the initial state (default: the "
                                                        "model's first; none: its own pose and a default rate)")
    p.add_argument("--out", metavar="FILE", help="the scenario file to write (default: ./xcheck_<model>.toml, "
                                                  "which pytest collects through xcheck's plugin)")
    p.add_argument("--force", action="store_true", help="replace --out if it exists")
    p.add_argument("--duration", help=f"the run: {DURATION_HELP} (default: derived from the motion, three of its "
                                      "own periods)")

    p = sub.add_parser("determine", help="static attitude determination: seed 002's tables, or a scenario's "
                                         "magnetometer + sun sensor study on its MuJoCo run")
    p.add_argument("scenario", nargs="?", help="a bundled name or a scenario .toml (its [determination] table)")
    p.add_argument("--seed002", action="store_true", help="print seed 002's tables beside xcheck's")
    p.add_argument("--json", metavar="PATH", help="write the study's results as JSON")
    p.add_argument("--out", metavar="DIR", help="also write a report (index.html, figures) into DIR/<time>/")

    p = sub.add_parser("league", help="the boxes benchmark: MuJoCo's integrators and ours beside ODE, Bullet, "
                                      "Simbody and DART's published figures")
    p.add_argument("--quick", action="store_true", help="one step, 1e-3 s (default: the benchmark's ten, 1e-4 ... 1e-3 s)")
    p.add_argument("--steps", metavar="DT,...", help="comma-separated steps [s] instead of the benchmark's")
    p.add_argument("--out", metavar="FILE.md", help="write the league table as Markdown (docs/league.md), its figure "
                                                   "beside it")
    p.add_argument("--json", metavar="PATH", help="write every row as JSON (schema xcheck.league/1)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")

    p = sub.add_parser("releases", help="every MuJoCo release from 3.2 to 4.0 on the bundled scenarios and the boxes "
                                        "(docs/mujoco-releases.md)")
    p.add_argument("scenarios", nargs="*", help="bundled scenario names, scenario .toml files or MJCF models (MODEL.xml, "
                                                "MODEL.xml#KEYFRAME), each run in every release's own environment "
                                                "(default: every bundled one)")
    p.add_argument("--mujoco", metavar="VERSIONS", help="comma-separated releases (default: the newest patch of every "
                                                        "minor release from 3.2.7 to 4.0.0)")
    p.add_argument("--out", metavar="FILE.md", help="write the release table as Markdown (docs/mujoco-releases.md)")
    p.add_argument("--json", metavar="PATH", help="write every release's probe as JSON")
    p.add_argument("--bisect", action="store_true",
                   help="find the first release whose free-body RK4 is fourth order, probing as few as a binary "
                        "search needs")

    p = sub.add_parser("mjx", help="MJX (MuJoCo's JAX port) in float32 and float64 on the bundled scenarios: what "
                                   "float32 costs (docs/mjx.md)")
    p.add_argument("scenarios", nargs="*", help="bundled names or .toml scenario files (default: every bundled one)")
    p.add_argument("--out", metavar="FILE.md", help="write the table as Markdown (docs/mjx.md)")
    p.add_argument("--json", metavar="PATH", help="write the rows as JSON")
    p.add_argument("--methods", help="comma-separated MJX methods (default: all six)")
    p.add_argument("--no-bench", action="store_true", help="leave out the steps-per-second rows")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")

    p = sub.add_parser("bench", help="steps per second of every method, ours and the engines'")
    p.add_argument("--json", metavar="PATH", help="write the rows as JSON (schema xcheck.bench/1)")
    p.add_argument("--quick", action="store_true", help="shorter runs, a smaller batch")
    p.add_argument("--methods", help="comma-separated methods (default: every method)")
    p.add_argument("--repeat", type=int, default=3, help="best of this many runs (default 3)")
    p.add_argument("--with", dest="with_engines", metavar="ENGINE",
                   help=WITH_HELP)
    return parser


def entry() -> None:
    """The ``xcheck`` command (and ``python -m xcheck``): :func:`main`, then out of the process at once. When main
    returns, everything the command writes is written and its workers are stopped; the interpreter's own
    teardown (numba's, LLVM's, MuJoCo's and Basilisk's modules released one by one) took another 0.3 s, a fifth of
    a quick ``xcheck converge``. Only a command that ran to its end leaves this way (exit 0 or 1): an interrupted
    or refused one may have left a worker half spawned, which multiprocessing's own exit handlers end before it
    reads a closed pipe (and prints that); so does a thread that still runs (none of xcheck's does)."""
    code = main()
    if code not in (EXIT_OK, EXIT_CHECK_FAILED) or any(t.is_alive() and not t.daemon for t in threading.enumerate()
                                                 if t is not threading.main_thread()):
        sys.exit(code)
    # the pool's queues hold named semaphores, each registered with multiprocessing's resource tracker and
    # unlinked by a finalizer that only the interpreter's exit (or the pool's collection) runs: skipped, the
    # tracker printed "There appear to be 3 leaked semaphore objects" now and then (2 in 6 converges). Those
    # finalizers (priority >= 0, as multiprocessing's own exit runs them first) cost nothing.
    run_finalizers = getattr(multiprocessing.util, "_run_finalizers", None)
    if run_finalizers is not None:
        run_finalizers(0)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (xcheck list | head): nothing more to say there
            pass
    os._exit(code)


def main(argv: list[str] | None = None) -> int:
    # xcheck never renders: without an OpenGL context MuJoCo's import skips GLFW's, which probes each library in
    # a Python subprocess of its own (80 ms a process; and a worker stopped while it imported left that probe
    # printing a BrokenPipeError). Inherited by the workers; a MUJOCO_GL of the user's is kept.
    os.environ.setdefault("MUJOCO_GL", "disable")
    with signals_as_interrupts():
        try:
            return _parse_and_run(argv)
        except KeyboardInterrupt as exc:  # before a command started (its own interrupts are reported by _run)
            return _interrupted(exc, None)


def _parse_and_run(argv) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse's own usage errors (exit 2, message printed), --help, --version
        return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
    if args.command is None:
        parser.print_help()
        return EXIT_BAD_INPUT
    warnings.filterwarnings("ignore", category=UserWarning, module=r"xcheck\.models")
    return _run(args)


def _interrupted(exc: KeyboardInterrupt, written) -> int:
    """Ctrl-C or SIGTERM, reported in one line: exit 130 or 143."""
    stop_repeating()
    # CPython marks an interrupt that leaves a string ``exec`` (a dataclass being made while a module imports)
    # "unhandled" even once it is caught, and ``python -m xcheck`` then ends by the signal (-2), not with 130.
    # Every string exec clears that mark as it starts.
    exec("pass", {})
    code = EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED
    print(stopped_line(code, written), file=sys.stderr)
    return code


def _run(args) -> int:
    """The command ``args.command`` (:func:`xcheck.commands.call`) with every failure a user can cause turned into a
    message and an exit code."""
    from .commands import Context, call

    ctx = Context(progress=Progress, started=_STARTED)
    from concurrent.futures.process import (
        BrokenProcessPool,  # an interrupt here is main's to report
    )

    try:
        try:
            return EXIT_OF[call(args.command, args, ctx).outcome]
        except BrokenProcessPool:
            # a worker died. A signal to the process group (Ctrl-C, kill -TERM) reaches the workers too, and
            # the broken pool can surface before this process's own signal does: give that a moment to land
            time.sleep(0.5)
            raise
        except KeyboardInterrupt:
            raise
        except Exception:
            if interrupts.SIGNALLED:  # the signal, turned into another error by the module it landed in
                raise as_interrupt() from None
            if interrupts.DIED:  # a worker's death, told by a signal that landed in such a module
                raise interrupts.worker_death() from None
            raise
    except BrokenProcessPool:
        print("xcheck: error: a worker process died (killed from outside, or out of memory); no report was written",
              file=sys.stderr)
        return EXIT_BUG
    except UserError as exc:
        print(f"xcheck: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        return _interrupted(exc, ctx.written[-1] if ctx.written else None)
    except BrokenPipeError:  # output piped into a reader that stopped (| head): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except MemoryError:
        print("xcheck: error: out of memory; use larger steps or a shorter duration", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # a file system that refuses after the checks (disk full, a folder removed meanwhile)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"xcheck: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:  # a bug: one line, unless XCHECK_DEBUG asks for the traceback
        if os.environ.get("XCHECK_DEBUG"):
            raise
        print(f"xcheck: internal error: {type(exc).__name__}: {exc}\nThis is a bug in xcheck {__version__}; please "
              "report it with the command you ran (set XCHECK_DEBUG=1 for the full traceback).", file=sys.stderr)
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
