"""The ``xcheck`` command line.

``xcheck list | converge | run | report | nightly | sweep | bench``. Exit codes: 0 when every check passed (and, for
``nightly``, nothing regressed), 1 when a check failed (or something regressed), 2 for bad input (the message names the file, key, argument or path), 130 when interrupted (Ctrl-C),
143 when terminated (SIGTERM), 3 for a bug in xcheck (a one-line message asking to report it; the traceback
with ``XCHECK_DEBUG=1``). Every input and output path is checked before any work starts.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing.util
import os
import sys
import threading
import time
import warnings
from contextlib import nullcontext
from pathlib import Path

from . import __version__
from .base import interrupts
from .base.errors import UsageError, UserError
from .base.interrupts import (
    Progress,
    Terminated,
    as_interrupt,
    signals_as_interrupts,
    stop_repeating,
)

_STARTED = time.perf_counter()  # when the command line was imported: the baseline of --timings

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_BUG, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 3, 130, 143
#: A study that cannot decide (issue 36): its steps show no asymptotic range, its reference is suspect or less
#: certain than a check, or it tests nothing; and no check failed.
EXIT_INCONCLUSIVE = 4
#: The exit code of each outcome (xcheck.results.OUTCOMES).
EXIT_OF = {"PASSED": EXIT_OK, "FAILED": EXIT_CHECK_FAILED, "INCONCLUSIVE": EXIT_INCONCLUSIVE}
#: The formats ``run --plot`` writes, by file ending.
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


#: The report folder this command has completed, if any: an interrupt after it says so, not "no report".
_WRITTEN: list = []


# ------------------------------------------------------------------------------------------------
def _csv_list(text, kind, name):
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


def _methods_arg(text):
    from .runners import RUNNERS, unknown_method

    methods = _csv_list(text, str, "--methods")
    for m in methods:
        if m not in RUNNERS:
            raise UsageError(f"--methods: {unknown_method(m)}")
    return methods


def _cmd_list(args) -> int:
    from .runners import RUNNERS
    from .scenario import ScenarioError, bundled_scenarios, load_scenario
    from .sweep.spec import bundled_sweeps, load_sweep

    for title, files, load in (("Bundled scenarios (models/scenarios/):", bundled_scenarios(), load_scenario),
                               ("\nBundled sweeps (models/sweeps/; xcheck sweep NAME):", bundled_sweeps(), load_sweep)):
        print(title)
        for name, path in files.items():
            try:
                desc = load(path).description
            except ScenarioError as exc:
                desc = f"(invalid: {exc})"
            print(f"  {name:28s} {desc}")
    print("\nMethods:")
    for name, r in RUNNERS.items():
        order = r.expected_order if r.expected_order is not None else "adaptive"
        print(f"  {name:22s} order {order!s:9s} {r.summary}")
    return EXIT_OK


def _print_study(st) -> None:
    from .study.checks import check_summary

    print(f"\n{st.name}: {st.outcome} (reference: {st.reference_used})")
    if st.reference_check:
        print(f"  reference: {st.reference_check['text']}")
    print(f"  {'method':22s} {'expected':>8s} {'observed':>8s} {'finest error':>13s}  status")
    for name, m in st.methods.items():
        obs = f"{m.observed_order:.2f}" if m.observed_order is not None else "—"
        exp = m.expected_order if m.expected_order is not None else "adaptive"
        err_text = "—" if m.finest is None else format(m.finest.attitude_error, ".2e")
        print(f"  {name:22s} {exp!s:>8s} {obs:>8s} {err_text:>13s}  {m.status_text}")
    for c in st.checks:
        if not c.passed:
            summary = check_summary(c, st.scenario.checks)
            detail = f"; {c.note}" if c.note and c.note != summary else ""
            print(f"  {'INCONCLUSIVE' if c.inconclusive else 'FAILED'} {c.name}: {summary}{detail}")
    for why in st.inconclusive:
        print(f"  INCONCLUSIVE: {why}")


def _clock_note(runner, dt: float, flag: str) -> str | None:
    """The note of ``runner``'s engine clock on the step ``dt`` (None: taken as given); a :class:`UsageError`
    naming ``flag`` for a step the engine's clock cannot take."""
    if runner.clock is None:
        return None
    try:
        return runner.clock(dt)
    except ValueError as exc:
        raise UsageError(f"{flag}: {str(exc).removeprefix('dt: ')} ({runner.name})") from None


def _steps_arg(text, scenario):
    from .scenario import check_steps

    steps = _csv_list(text, float, "--steps")
    try:
        return list(check_steps(steps, scenario.duration))
    except ValueError as exc:
        raise UsageError(f"--steps: {exc} (scenario {scenario.name}, duration {scenario.duration:g} s)") from None


def _cmd_converge(args) -> int:
    from .base.pool import worker_pool
    from .engines import ENGINES, available
    from .report.build import worker_modules

    # A study is quicker in this process than shared with workers, which each pay 1-1.5 s of imports and
    # compiled-code loading before their first run, except for the methods of an engine whose import is costly
    # (Basilisk's: 0.5 s more, and the longest runs). With one installed (and not left out by --methods) one
    # worker starts before anything is imported here, imports it, and runs its methods while this process runs
    # the rest. --workers N: that many processes for the whole study; --workers 1: this process alone.
    costly = any(e.to_workers and available(e.name) and (args.methods is None or e.name in args.methods)
                 for e in ENGINES.values())
    size = args.workers - 1 if args.workers and args.workers > 1 else (1 if args.workers is None and costly else 0)
    with worker_pool(size, warm=worker_modules(figures=False)) if size else nullcontext() as pool:
        return _converge(args, pool)


def _converge(args, pool) -> int:
    from .base.files import check_output_dir, check_output_file, write_json_atomic
    from .runners import RUNNERS
    from .scenario import resolve_scenario
    from .study import default_methods, run_study

    scenario = resolve_scenario(args.scenario)
    methods = _methods_arg(args.methods) if args.methods is not None else None
    steps = _steps_arg(args.steps, scenario) if args.steps is not None else None
    for m in (methods or default_methods(scenario)) if steps else ():  # an unknown name: run_study's refusal
        for dt in steps if m in RUNNERS else ():
            _clock_note(RUNNERS[m], dt, "--steps")
    if args.json:
        check_output_file(args.json, "--json", suffixes=(".json",))
    if args.out:
        check_output_dir(args.out, "--out")
    t0 = time.perf_counter()
    progress = Progress()
    # a run's wall time is repeated for a meaningful figure only where one is written (the table shows none)
    st = run_study(scenario, methods=methods, steps=steps, quick=args.quick, workers=1 if pool is None else None,
                   progress=progress, timing=bool(args.json or args.out), pool=pool, here=pool is not None)
    _print_study(st)
    if args.json:
        write_json_atomic(args.json, st.data)
    if args.out:
        from .report.plots import scenario_figures

        files = scenario_figures(st.data, st.series, args.out)
        print(f"  figures: {', '.join(str(Path(args.out) / f) for f, _ in files)}")
    print(f"wall time {time.perf_counter() - t0:.1f} s")
    return EXIT_OF[st.outcome]


def _cmd_run(args) -> int:
    from .base.files import check_output_file, write_trajectory_csv
    from .runners import RUNNERS
    from .scenario import resolve_scenario
    from .study.single import run_once
    from .trajectory import check_step

    scenario = resolve_scenario(args.scenario)
    if args.method not in RUNNERS:
        from .runners import unknown_method

        raise UsageError(f"--method: {unknown_method(args.method)}")
    runner = RUNNERS[args.method]
    if args.rtol is not None and not runner.adaptive:
        raise UsageError(f"--rtol: {args.method} is a fixed-step method; a tolerance applies to an adaptive one "
                         f"({', '.join(n for n, r in RUNNERS.items() if r.adaptive)})")
    if args.rtol is not None and not (math.isfinite(args.rtol) and 0 < args.rtol < 1):
        raise UsageError(f"--rtol: expected a relative tolerance in (0, 1), got {args.rtol:g}")
    try:
        check_step(args.dt, scenario.duration, runs_at_once=1)
    except ValueError as exc:
        raise UsageError(f"--dt: {exc} (scenario {scenario.name}, duration {scenario.duration:g} s)") from None
    clock_note = _clock_note(runner, args.dt, "--dt")
    if args.csv:
        check_output_file(args.csv, "--csv", suffixes=(".csv",))
    if args.plot:
        check_output_file(args.plot, "--plot", suffixes=PLOT_SUFFIXES)
    if clock_note:
        print(f"note: {clock_note}")
    one = run_once(scenario, runner, args.dt, args.rtol)
    traj, err = one.traj, one.error
    print(f"{scenario.name} / {args.method} at dt = {args.dt:g} s: {traj.status} ({len(traj.t) - 1} steps, "
          f"{one.wall_time:.3g} s)")
    if traj.message:
        print(f"  {traj.message}")
    if one.no_reference:
        print(f"  no reference: {one.no_reference}")
    elif one.measured_at_end:
        print(f"  attitude error at t = {traj.t[-1]:g} s: {err[-1]:.3e} rad (against the {scenario.reference} "
              f"reference); max over the grid {one.max_error:.3e} rad")
        print(f"  body-rate error at the end: {one.rate_error:.3e} rad/s")
    if args.csv:
        write_trajectory_csv(args.csv, f"{scenario.name} / {args.method}, dt = {args.dt:g} s, status {traj.status}",
                             traj.t, traj.q, traj.omega, err, traj.extras.get("euler"))
        print(f"  trajectory: {args.csv}")
    if args.plot:
        from .report.plots import run_figure

        run_figure(args.plot, f"{scenario.name} / {args.method}, dt = {args.dt:g} s", traj, err)
        print(f"  plot: {args.plot}")
    return EXIT_OK if one.ok else EXIT_CHECK_FAILED


def _cmd_report(args) -> int:
    from .report.build import build_report

    t0 = time.perf_counter()
    _with_engines(args)
    outcome = build_report(args.scenarios, args.out, quick=args.quick, workers=args.workers, run_bench=args.bench,
                           trajectories=args.trajectories, progress=Progress(), written=_WRITTEN.append,
                           started=_STARTED)
    if args.timings:
        print(outcome.timings(), file=sys.stderr)
    for st in outcome.studies:
        _print_study(st)
    print(f"\nreport: {outcome.folder}/index.html ({outcome.outcome}); wall time {time.perf_counter() - t0:.1f} s")
    return EXIT_OF[outcome.outcome]


def _cmd_nightly(args) -> int:
    """The full report, compared with the history, then recorded in it (see :mod:`xcheck.history.nightly`)."""
    from .base.files import check_output_dir
    from .history import nightly
    from .report.build import resolve_scenarios

    if args.keep is not None and args.keep < 1:
        raise UsageError(f"--keep: expected a positive number of report folders, got {args.keep}")
    if args.last < 1:
        raise UsageError(f"--last: expected a positive number of runs, got {args.last}")
    for name, value, top in (("--error-factor", args.error_factor, None), ("--order-drop", args.order_drop, None),
                             ("--speed-drop", args.speed_drop, 1.0)):
        if not (value > 0 and (top is None or value <= top) and value != float("inf")):
            raise UsageError(f"{name}: expected a positive number{' at most 1' if top else ''}, got {value}")
    thresholds = nightly.H.Thresholds(error_factor=args.error_factor, order_drop=args.order_drop,
                                      speed_drop=args.speed_drop)
    versions = []
    if args.mujoco is not None:
        versions = _releases_arg(args.mujoco)
    scenarios = resolve_scenarios(args.scenarios)
    check_output_dir(args.out, "--out")
    if args.history is not None and not args.history.strip():
        raise UsageError("--history: expected a SQLite file or a postgresql:// URL, got an empty string")
    location = args.history or nightly.default_history(args.out)
    outcome = nightly.run_nightly(scenarios, args.out, location=location, baseline=args.baseline, last=args.last,
                                  thresholds=thresholds, versions=versions, quick=args.quick, workers=args.workers,
                                  bench=args.bench, keep=args.keep, progress=Progress(), written=_WRITTEN.append,
                                  started=_STARTED)
    for st in outcome.report.studies:
        _print_study(st)
    print()
    for cmp in outcome.comparisons:
        for line in cmp.lines():
            print(line)
    if outcome.removed:
        n = len(outcome.removed)
        print(f"--keep {args.keep}: removed {n} older report folder{'s' * (n > 1)}")
    print(f"\nnightly: run {outcome.run_id} recorded in {nightly.H.display(location)}; report "
          f"{outcome.report.folder}/index.html ({outcome.verdict()}); wall time {outcome.wall_time:.1f} s")
    return EXIT_CHECK_FAILED if outcome.regressions else EXIT_OF[outcome.report.outcome]


def _cmd_bench(args) -> int:
    from .base.files import check_output_file
    from .bench import main as bench_main

    _with_engines(args)
    if args.repeat < 1:
        raise UsageError(f"--repeat: expected a positive number of runs, got {args.repeat}")
    argv = []
    if args.json:
        check_output_file(args.json, "--json", suffixes=(".json",))
        argv += ["--json", args.json]
    if args.quick:
        argv.append("--quick")
    if args.methods is not None:
        argv += ["--methods", ",".join(_methods_arg(args.methods))]
    argv += ["--repeat", str(args.repeat)]
    return bench_main(argv)


def _engine_variables() -> None:
    """``$XCHECK_WITH`` and ``$XCHECK_WITHOUT`` as ``--with`` is: names of engines (opt-in ones for the first, installed),
    or a refusal naming the variable (a typo once left MJX out silently)."""
    from .engines import ENGINES, WITH_VARIABLE, WITHOUT_VARIABLE, available

    for variable in (WITH_VARIABLE, WITHOUT_VARIABLE):
        text = os.environ.get(variable, "")
        names = [n.strip() for n in text.split(",") if n.strip()]
        for name in names:
            if variable == WITH_VARIABLE and not (name in ENGINES and ENGINES[name].opt_in):
                raise UsageError(f"${variable}={text!r}: {name!r} is not an opt-in engine (expected some of "
                                 f"{', '.join(n for n, e in ENGINES.items() if e.opt_in)})")
            if variable == WITH_VARIABLE and not available(name):
                raise UsageError(f"${variable}={text!r}: {name} is not installed here: pip install 'xcheck[{name}]'")
            if variable == WITHOUT_VARIABLE and (name not in ENGINES or name == "mujoco"):
                raise UsageError(f"${variable}={text!r}: {name!r} is not an optional engine (expected some of "
                                 f"{', '.join(n for n in ENGINES if n != 'mujoco')})")


def _with_engines(args) -> None:
    """``--with ENGINE[,ENGINE]``: an opt-in engine's methods join every study of this command (and its workers'),
    through ``$XCHECK_WITH``; refused, naming what to install, where the engine is not installed."""
    if not getattr(args, "with_engines", None):
        return
    from .engines import ENGINES, WITH_VARIABLE, available

    names = _csv_list(args.with_engines, str, "--with")
    opt_in = [n for n, e in ENGINES.items() if e.opt_in]
    for name in names:
        if name not in opt_in:
            raise UsageError(f"--with: {name!r} is not an opt-in engine (expected one of {', '.join(opt_in)}); "
                             "the others run whenever they are installed")
        if not available(name):
            raise UsageError(f"--with {name}: {name} is not installed here: pip install 'xcheck[{name}]'")
    os.environ[WITH_VARIABLE] = ",".join(names)


def _markdown_and_json(args):
    """A docs command's ``--out FILE.md`` (returned, None when not given) and ``--json PATH``, checked before any
    work."""
    from .base.files import check_output_file

    out = check_output_file(args.out, "--out", suffixes=(".md",)) if args.out else None
    if args.json:
        check_output_file(args.json, "--json", suffixes=(".json",))
    return out


def _cmd_league(args) -> int:
    """The boxes benchmark's league table: MuJoCo's integrators and ours beside the published engines."""
    from .base.files import write_json_atomic
    from .league.boxes import STEPS
    from .league.run import QUICK_STEPS, run_league
    from .league.table import checks, markdown, table_rows

    given = args.steps is not None
    steps = tuple(_csv_list(args.steps, float, "--steps")) if given else (QUICK_STEPS if args.quick else STEPS)
    if given and args.quick:
        raise UsageError("--steps and --quick: give one (--quick is --steps 0.001)")
    for dt in steps:
        if dt > 0.01:
            raise UsageError(f"--steps: {dt:g} s is coarser than the boxes can be stepped (at most 0.01 s)")
        if dt < 1e-5:
            raise UsageError(f"--steps: {dt:g} s is finer than 1e-05 s (a million steps of the benchmark's 10 s, "
                             "each kept in memory)")
    out = _markdown_and_json(args)
    if out is not None:
        from .base.files import check_output_file
        from .league.table import FIGURE

        check_output_file(out.parent / FIGURE, "--out (its figure, beside it)", suffixes=(".png",))
    workers = args.workers or os.cpu_count() or 1
    from .base.pool import worker_pool

    with worker_pool(workers, warm=("xcheck.league.run", "mujoco")) if workers > 1 else nullcontext() as pool:
        rows = run_league(steps, pool=pool, progress=Progress())
    for case in ("complex", "simple"):
        head, body = table_rows(rows, case, steps)
        print(f"\nboxes, {case} case")
        widths = [max(len(h), *(len(r[k]) for r in body)) for k, h in enumerate(head)]
        print("  ".join(h.ljust(w) for h, w in zip(head, widths)))
        for r in body:
            print("  ".join(c.ljust(w) for c, w in zip(r, widths)))
    failed = [c for c in checks(rows) if not c[1]]
    for what, _, why in failed:
        print(f"FAILED {what}: {why}")
    from .base.files import write_bytes_atomic, write_text_atomic
    from .base.interrupts import signals_deferred
    from .versions import versions

    v = versions()
    if out is not None:  # everything made first, then written together: all of it or none
        from .league.table import draw

        file, _, png = draw(rows, steps)
        command = "xcheck league" + (" --quick" if args.quick else "") + (f" --steps {args.steps}" if args.steps else "")
        text = markdown(rows, steps, version=v["xcheck"], versions={k: v[k] for k in ("mujoco", "numpy", "scipy")},
                        command=f"{command} --out {out.name}")
    with signals_deferred():
        if args.json:
            write_json_atomic(args.json, {"schema": "xcheck.league/1", "versions": v, "steps": list(steps),
                                          "rows": rows})
            _WRITTEN.append(args.json)
        if out is not None:
            write_bytes_atomic(out.parent / file, png)
            write_text_atomic(out, text + f"\n![{file}]({file})\n")
            _WRITTEN.append(out)
    if out is not None:
        print(f"league table: {out} (figure {out.parent / file})")
    return EXIT_CHECK_FAILED if failed else EXIT_OK


def _releases_arg(text: str) -> list[str]:
    """``--mujoco``'s releases, each on the package index (or a note where the index cannot say), before any work."""
    from .history.matrix import check_on_index, parse_versions

    try:
        versions = parse_versions(text)
        note = check_on_index(versions)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if note:
        print(note, file=sys.stderr)
    return versions


def _cmd_releases(args) -> int:
    """Every MuJoCo release on the bundled scenarios and the boxes: docs/mujoco-releases.md, or a bisection."""
    from .base.files import write_json_atomic, write_text_atomic
    from .league.releases import (
        PROBE_SCENARIO,
        RELEASES,
        ReleaseError,
        bisect,
        is_fourth_order,
        markdown,
        release_key,
        rk4_order,
        run_probe,
    )

    versions = _releases_arg(args.mujoco) if args.mujoco is not None else list(RELEASES)
    out = _markdown_and_json(args)
    if args.bisect:
        if out is not None:
            raise UsageError("--out: a bisection probes only some releases; run without --bisect for the table")

        def good(v):
            try:
                return is_fourth_order(run_probe(v, scenarios=[PROBE_SCENARIO]))
            except ReleaseError as exc:
                raise UsageError(str(exc)) from None

        first, seen = bisect(versions, good)
        probed = ", ".join(f"{v} {'4th' if ok else 'not 4th'}" for v, ok in sorted(seen.items(), key=lambda kv: release_key(kv[0])))
        print(f"free-body RK4 ({PROBE_SCENARIO}) fourth order from: {first or f'none of {versions[0]} ... {versions[-1]}'}"
              f" ({len(seen)} of {len(versions)} releases probed: {probed})")
        if args.json:
            write_json_atomic(args.json, {"schema": "xcheck.releases-bisect/1", "first_fourth_order": first,
                                          "probed": seen})
        return EXIT_OK
    from .scenario import resolve_scenario

    for name in args.scenarios:
        resolve_scenario(name)  # a bad name or file: said before any release is made
    probes, failures = {}, {}
    progress = Progress()
    for k, v in enumerate(versions):
        progress(k, len(versions), f"MuJoCo {v}")
        try:
            probes[v] = run_probe(v, scenarios=args.scenarios or None, log=lambda *a: None)
        except ReleaseError as exc:
            failures[v] = str(exc).split(": ", 1)[-1]
            print(f"MuJoCo {v}: not run ({failures[v]})")
            continue
        d = probes[v]
        passed = sum(s["passed"] for s in d["scenarios"].values())
        order = rk4_order(d)
        print(f"MuJoCo {v}: {passed} of {len(d['scenarios'])} scenarios passed; free-body RK4 order "
              f"{'—' if order is None else f'{order:.2f}'}")
    progress(len(versions), len(versions), "")
    first = None  # the oldest probed release from which every probed release is fourth order
    for v in reversed([v for v in versions if v in probes]):
        if not is_fourth_order(probes[v]):
            break
        first = v
    print(f"free-body RK4 fourth order from: {first or 'none of these'}")
    if args.json:
        write_json_atomic(args.json, {"schema": "xcheck.releases/1", "probes": probes, "failures": failures,
                                      "first_fourth_order": first})
    if out is not None:
        command = ("xcheck releases" + (" " + " ".join(args.scenarios) if args.scenarios else "")
                   + (f" --mujoco {args.mujoco}" if args.mujoco else "") + f" --out {out.name}")
        write_text_atomic(out, markdown(probes, failures, version=__version__, command=command, first_good=first))
        print(f"release table: {out}")
    return EXIT_OK


def _cmd_mjx(args) -> int:
    """MJX in float32 and float64 on the bundled scenarios, and its batched steps per second: docs/mjx.md."""
    from .base.files import write_json_atomic, write_text_atomic
    from .engines import available

    if not available("mjx"):
        raise UsageError("mjx: MJX is not installed here: pip install 'xcheck[mjx]' (the PyPI packages mujoco-mjx "
                         "and jax)")
    out = _markdown_and_json(args)
    from .league.precision import floors, markdown, run_precision_studies
    from .scenario import resolve_scenario

    for name in args.scenarios:
        resolve_scenario(name)  # a bad name or file: said before any work
    methods = None
    if args.methods is not None:
        from .league.precision import mjx_methods

        methods = _csv_list(args.methods, str, "--methods")
        for m in methods:
            if m not in mjx_methods():
                raise UsageError(f"--methods: {m!r} is not MJX's (expected some of {', '.join(mjx_methods())})")
    studies = run_precision_studies(args.scenarios or None, methods=methods, workers=args.workers,
                                    progress=Progress())
    rows = floors(studies)
    bench = []
    if not args.no_bench:
        from .bench import run_bench

        bench = [r for r in run_bench(repeat=2, quick=True, methods=["mjx-rk4", "mjx-rk4-x64", "formulation-2",
                                                                     "lie-rkmk4", "mujoco-rk4"])
                 if r["batch"] > 1 or "mj_step" in r["method"] or r["method"].startswith("mjx")]
    width = max(len(r["scenario"]) for r in rows)
    for r in rows:
        if r["method"].startswith("mjx"):
            order = "—" if r["observed"] is None else f"{r['observed']:.2f}"
            floor = "—" if r["floor"] is None else f"{r['floor']:.2g}"
            print(f"{r['scenario']:<{width}}  {r['method']:<18} order {order:>5}  finest error {floor:>8} rad")
    for row in bench:
        print(f"{row['method']:<45} batch {row['batch']:>6}  {row['steps_per_second']:.3g} body-steps/s")
    if args.json:
        write_json_atomic(args.json, {"schema": "xcheck.mjx/1", "rows": rows, "bench": bench})
    if out is not None:
        from .versions import package_version, versions

        v = versions()
        command = ("xcheck mjx" + (" " + " ".join(args.scenarios) if args.scenarios else "")
                   + (f" --methods {args.methods}" if args.methods else "") + f" --out {out.name}")
        text = markdown(rows, bench, version=__version__, command=command,
                        versions={"mujoco": v["mujoco"], "mujoco-mjx": package_version("mujoco-mjx"),
                                  "jax": package_version("jax")})
        write_text_atomic(out, text)
        print(f"MJX table: {out}")
    return EXIT_OK


def _cmd_sweep(args) -> int:
    """A sweep: every cell a cross-check (see :mod:`xcheck.sweep.spec` and :mod:`xcheck.sweep.run`)."""
    from .base.files import check_output_dir
    from .sweep.run import PARTIAL_LOG, run_sweep
    from .sweep.spec import MAX_CELLS, resolve_sweep

    if args.jobs is not None and args.jobs < 1:
        raise UsageError(f"--jobs: expected a positive number of processes, got {args.jobs}")
    if args.scheduler and args.executor != "dask":
        raise UsageError("--scheduler: only with --executor dask")
    if args.max_cells is not None and args.max_cells < 1:
        raise UsageError(f"--max-cells: expected a positive number of cells, got {args.max_cells}")
    spec = resolve_sweep(args.spec, max_cells=MAX_CELLS if args.max_cells is None else args.max_cells)
    check_output_dir(args.out, "--out")
    cpus = os.cpu_count() or 1
    jobs = min(args.jobs or cpus, cpus)
    if args.jobs and args.jobs > jobs:
        print(f"note: --jobs {args.jobs}: {jobs} worker processes, one per CPU (more would only share them)")
    n = len(spec.cells)
    print(f"sweep {spec.path.stem}: {n} cell{'s' * (n != 1)} x {len(spec.steps)} steps, base {spec.base.name}, on "
          f"{'a Dask cluster' if args.executor == 'dask' else f'{jobs} process' + 'es' * (jobs > 1)}")
    try:
        out = run_sweep(spec, args.out, jobs=jobs, resume=args.resume, kind=args.executor, scheduler=args.scheduler,
                        progress=Progress())
    except KeyboardInterrupt:
        log = Path(args.out) / spec.path.stem / PARTIAL_LOG
        if log.exists():
            print(f"\nxcheck: the cells finished so far are kept in {log}; run again with --resume to skip them",
                  file=sys.stderr)
        raise
    passed = sum(r["passed"] for r in out.records)
    t = out.timings
    if out.ran:
        print(f"{out.ran} cells in {out.wall_time:.1f} s: {t['cells_per_second']:.2f} cells/s; start-up "
              f"{t['executor_start']:.2f} s; per cell (median): model and torque {1e3 * t['context']:.1f} ms, reference "
              f"{1e3 * t['reference']:.1f} ms, compute {1e3 * t['compute']:.1f} ms")
    if out.reused:
        print(f"{out.reused} cells from the earlier run (--resume)")
    from .results import outcome_of

    outcome = outcome_of(r.get("outcome") or ("PASSED" if r["passed"] else "FAILED") for r in out.records)
    undecided = sum(r.get("outcome") == "INCONCLUSIVE" for r in out.records)
    print(f"sweep: {out.folder}/index.html; {passed} of {n} cells passed every check"
          + (f", {undecided} inconclusive" if undecided else ""))
    return EXIT_OF[outcome]


def _cmd_init(args) -> int:
    """The scenario file an MJCF file stands for, every key present and commented, to edit."""
    from .base.files import check_output_file, write_text_atomic
    from .paths import input_problem
    from .scenario import (
        foreign_model,
        is_model_arg,
        model_scenario_text,
        split_model_arg,
    )

    foreign = foreign_model(args.model)
    if foreign:
        raise UsageError(f"MODEL: {foreign}")
    if not is_model_arg(args.model):
        raise UsageError(f"MODEL: expected an MJCF file (.xml, optionally #KEYFRAME), got {args.model!r}")
    path, keyframe = split_model_arg(args.model)
    keyframe = args.keyframe if args.keyframe is not None else keyframe
    problem = input_problem(path, "MJCF file")
    if problem:
        raise UsageError(f"MODEL: {problem}")
    out = Path(args.out) if args.out else Path(f"xcheck_{path.stem}.toml")
    check_output_file(out, "--out", suffixes=(".toml",))
    if out.exists() and not args.force:
        raise UsageError(f"--out: {out} exists; give another --out, or --force to replace it")
    relative = os.path.relpath(path.resolve(), out.resolve().parent)
    text, assumptions = model_scenario_text(path, keyframe, model_ref=Path(relative).as_posix())
    write_text_atomic(out, text)
    _WRITTEN.append(out)
    print(f"wrote {out}: the scenario xcheck assumes for {path.name}; edit it, then: xcheck report {out}")
    for a in assumptions:
        print(f"  - {a}")
    return EXIT_OK


def _cmd_determine(args) -> int:
    """Seed 002's tables reproduced (``--seed002``), or a scenario's attitude-determination study alone."""
    from .base.files import check_output_dir, check_output_file

    if args.seed002 == bool(args.scenario):
        raise UsageError("give a SCENARIO (its [determination] study) or --seed002 (the seed's tables), one of them")
    if args.seed002:
        from .determination.seed002 import report_lines, reproduce

        rep = reproduce()
        print("\n".join(report_lines(rep)))
        return EXIT_OK if rep["passed"] else EXIT_CHECK_FAILED
    from .determination.sensors import DEFAULT_SPEC
    from .determination.study import run_determination, summary_lines
    from .scenario import resolve_scenario

    scenario = resolve_scenario(args.scenario)
    if args.json:
        check_output_file(args.json, "--json", suffixes=(".json",))
    if args.out:
        check_output_dir(args.out, "--out")
    if scenario.determination is None:
        print(f"{scenario.name} has no [determination] table: the defaults (see the README)", file=sys.stderr)
    spec = scenario.determination or DEFAULT_SPEC
    data, series = run_determination(scenario, spec)
    for line in summary_lines(data):
        print(line)
    if args.json:
        from .base.files import write_json_atomic

        write_json_atomic(Path(args.json), data)
    if args.out:
        from .report.determination import draw_determination, write_determination

        folder = write_determination(data, draw_determination(data, series), args.out)
        _WRITTEN.append(folder)
        print(f"report: {folder}/index.html")
    return EXIT_OK if data["passed"] else EXIT_CHECK_FAILED


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="xcheck", description="MuJoCo-validated rigid-body attitude cross-checker")
    parser.add_argument("--version", action="version", version=f"xcheck {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("list", help="bundled scenarios and methods")
    p.set_defaults(func=_cmd_list)

    p = sub.add_parser("converge", help="one convergence study")
    p.add_argument("scenario", help="a bundled scenario name, a scenario .toml file, or an MJCF model alone "
                                    "(MODEL.xml, MODEL.xml#KEYFRAME)")
    p.add_argument("--methods", help="comma-separated methods (default: the scenario's, or all)")
    p.add_argument("--steps", help="comma-separated steps in seconds (default: the scenario's)")
    p.add_argument("--quick", action="store_true", help="the scenario's quick steps")
    p.add_argument("--json", metavar="PATH", help="write the results (schema xcheck.convergence/1)")
    p.add_argument("--out", metavar="DIR", help="write the figures into DIR")
    p.add_argument("--workers", type=int, default=None,
                   help="processes for the study, this one included (default: this process, and one worker for "
                        "Basilisk's methods when it is installed)")
    p.set_defaults(func=_cmd_converge)

    p = sub.add_parser("run", help="one trajectory")
    p.add_argument("scenario", help="a bundled scenario name, a scenario .toml file, or an MJCF model alone "
                                    "(MODEL.xml, MODEL.xml#KEYFRAME)")
    p.add_argument("--method", required=True)
    p.add_argument("--dt", type=float, required=True, help="step [s] (an adaptive method's output step)")
    p.add_argument("--rtol", type=float, help="an adaptive method's relative tolerance (default: its own)")
    p.add_argument("--csv", metavar="PATH", help="write the trajectory as CSV")
    p.add_argument("--plot", metavar="PATH", help="write a PNG plot")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("report", help="the full cross-check report (the main job)")
    p.add_argument("scenarios", nargs="*", help="bundled names, .toml scenario files or MJCF models (MODEL.xml, "
                                                "MODEL.xml#KEYFRAME; default: every bundled scenario)")
    p.add_argument("--out", default="reports", metavar="DIR", help="where reports go (default: ./reports)")
    p.add_argument("--quick", action="store_true", help="fewer steps, for a fast look")
    p.add_argument("--bench", action="store_true", help="also run the benchmark into the appendix")
    p.add_argument("--timings", action="store_true", help="print where the time went (phases, on stderr)")
    p.add_argument("--trajectories", action="store_true",
                   help="also write every method's finest run as CSV (trajectories/, ~4 MB a scenario)")
    p.add_argument("--with", dest="with_engines", metavar="ENGINE",
                   help="an opt-in engine's methods too: mjx (MJX's RK4, Euler and implicitfast, float32 and x64; "
                        "pip install 'xcheck[mjx]')")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")
    p.set_defaults(func=_cmd_report)

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
    p.set_defaults(func=_cmd_nightly)

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
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("init", help="write the scenario file an MJCF model stands for (every key, commented)")
    p.add_argument("model", metavar="MODEL", help="an MJCF file (MODEL.xml, or MODEL.xml#KEYFRAME)")
    p.add_argument("--keyframe", metavar="NAME", help="the keyframe that holds the initial state (default: the "
                                                        "model's first; none: its own pose and a default rate)")
    p.add_argument("--out", metavar="FILE", help="the scenario file to write (default: ./xcheck_<model>.toml, "
                                                  "which pytest collects through xcheck's plugin)")
    p.add_argument("--force", action="store_true", help="replace --out if it exists")
    p.set_defaults(func=_cmd_init)

    p = sub.add_parser("determine", help="static attitude determination: seed 002's tables, or a scenario's "
                                         "magnetometer + sun sensor study on its MuJoCo run")
    p.add_argument("scenario", nargs="?", help="a bundled name or a scenario .toml (its [determination] table)")
    p.add_argument("--seed002", action="store_true", help="print seed 002's tables beside xcheck's")
    p.add_argument("--json", metavar="PATH", help="write the study's results as JSON")
    p.add_argument("--out", metavar="DIR", help="also write a report (index.html, figures) into DIR/<time>/")
    p.set_defaults(func=_cmd_determine)

    p = sub.add_parser("league", help="the boxes benchmark: MuJoCo's integrators and ours beside ODE, Bullet, "
                                      "Simbody and DART's published figures")
    p.add_argument("--quick", action="store_true", help="one step, 1e-3 s (default: the benchmark's ten, 1e-4 ... 1e-3 s)")
    p.add_argument("--steps", metavar="DT,...", help="comma-separated steps [s] instead of the benchmark's")
    p.add_argument("--out", metavar="FILE.md", help="write the league table as Markdown (docs/league.md), its figure "
                                                   "beside it")
    p.add_argument("--json", metavar="PATH", help="write every row as JSON (schema xcheck.league/1)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")
    p.set_defaults(func=_cmd_league)

    p = sub.add_parser("releases", help="every MuJoCo release from 3.2 to 4.0 on the bundled scenarios and the boxes "
                                        "(docs/mujoco-releases.md)")
    p.add_argument("scenarios", nargs="*", help="bundled scenario names (default: every bundled one)")
    p.add_argument("--mujoco", metavar="VERSIONS", help="comma-separated releases (default: the newest patch of every "
                                                        "minor release from 3.2.7 to 4.0.0)")
    p.add_argument("--out", metavar="FILE.md", help="write the release table as Markdown (docs/mujoco-releases.md)")
    p.add_argument("--json", metavar="PATH", help="write every release's probe as JSON")
    p.add_argument("--bisect", action="store_true",
                   help="find the first release whose free-body RK4 is fourth order, probing as few as a binary "
                        "search needs")
    p.set_defaults(func=_cmd_releases)

    p = sub.add_parser("mjx", help="MJX (MuJoCo's JAX port) in float32 and float64 on the bundled scenarios: what "
                                   "float32 costs (docs/mjx.md)")
    p.add_argument("scenarios", nargs="*", help="bundled names or .toml scenario files (default: every bundled one)")
    p.add_argument("--out", metavar="FILE.md", help="write the table as Markdown (docs/mjx.md)")
    p.add_argument("--json", metavar="PATH", help="write the rows as JSON")
    p.add_argument("--methods", help="comma-separated MJX methods (default: all six)")
    p.add_argument("--no-bench", action="store_true", help="leave out the steps-per-second rows")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPU count)")
    p.set_defaults(func=_cmd_mjx)

    p = sub.add_parser("bench", help="steps per second of every method, ours and the engines'")
    p.add_argument("--json", metavar="PATH", help="write the rows as JSON (schema xcheck.bench/1)")
    p.add_argument("--quick", action="store_true", help="shorter runs, a smaller batch")
    p.add_argument("--methods", help="comma-separated methods (default: every method)")
    p.add_argument("--repeat", type=int, default=3, help="best of this many runs (default 3)")
    p.add_argument("--with", dest="with_engines", metavar="ENGINE",
                   help="an opt-in engine's methods too: mjx (MJX's RK4, Euler and implicitfast, float32 and x64; "
                        "pip install 'xcheck[mjx]')")
    p.set_defaults(func=_cmd_bench)
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
    if not hasattr(args, "func"):
        parser.print_help()
        return EXIT_BAD_INPUT
    if getattr(args, "workers", None) is not None and args.workers < 1:
        print("xcheck: error: --workers: expected a positive number of processes", file=sys.stderr)
        return EXIT_BAD_INPUT
    cpus = os.cpu_count() or 1
    if getattr(args, "workers", None) is not None and args.workers > cpus:  # 1000 made a 2 s job take 107 s
        print(f"note: --workers {args.workers}: {cpus} worker processes, one per CPU (more would only share them "
              "and each holds ~55 MB)", file=sys.stderr)
        args.workers = cpus
    warnings.filterwarnings("ignore", category=UserWarning, module=r"xcheck\.models")
    return _run(args)


def _interrupted(exc: KeyboardInterrupt, written) -> int:
    """Ctrl-C or SIGTERM, reported in one line: exit 130 or 143."""
    stop_repeating()
    # CPython marks an interrupt that leaves a string ``exec`` (a dataclass being made while a module imports)
    # "unhandled" even once it is caught, and ``python -m xcheck`` then ends by the signal (-2), not with 130.
    # Every string exec clears that mark as it starts.
    exec("pass", {})
    what = f"the report {written} is complete" if written else "no report was written"
    print(f"\nxcheck: {'terminated' if isinstance(exc, Terminated) else 'interrupted'}; {what}", file=sys.stderr)
    return EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED


def _run(args) -> int:
    """``args.func(args)`` with every failure a user can cause turned into a message and an exit code."""
    _WRITTEN.clear()  # nothing written yet by this command
    from concurrent.futures.process import (
        BrokenProcessPool,  # an interrupt here is main's to report
    )

    try:
        try:
            _engine_variables()
            return args.func(args)
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
            raise
    except BrokenProcessPool:
        print("xcheck: error: a worker process died (killed from outside, or out of memory); no report was written",
              file=sys.stderr)
        return EXIT_BUG
    except UserError as exc:
        print(f"xcheck: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        return _interrupted(exc, _WRITTEN[-1] if _WRITTEN else None)
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
