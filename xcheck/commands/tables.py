"""The commands that write the docs' tables: ``xcheck league`` (the boxes benchmark beside the published engines,
docs/league.md), ``xcheck releases`` (every MuJoCo release, docs/mujoco-releases.md) and ``xcheck mjx`` (MJX in
float32 and float64, docs/mjx.md)."""

from __future__ import annotations

import os
from contextlib import nullcontext
from dataclasses import dataclass

from .. import __version__
from ..base.errors import UsageError
from . import Context, Outcome
from .arguments import csv_list, markdown_and_json, releases_arg


@dataclass
class TableOutcome(Outcome):
    rows: object  # the command's rows (league rows, release probes, MJX floors)


def league(*, quick: bool, steps: str | None, out: str | None, json: str | None, workers: int | None,
           ctx: Context) -> TableOutcome:
    """The boxes benchmark's league table: MuJoCo's integrators and ours beside the published engines; FAILED when
    one of its checks does (every fourth-order run within 1e-8)."""
    from ..base.files import (
        check_output_file,
        write_bytes_atomic,
        write_json_atomic,
        write_text_atomic,
    )
    from ..base.interrupts import signals_deferred
    from ..base.pool import worker_pool
    from ..league.boxes import STEPS
    from ..league.run import QUICK_STEPS, run_league
    from ..league.table import FIGURE, checks, draw, markdown, table_rows
    from ..versions import versions

    given = steps is not None
    dts = tuple(csv_list(steps, float, "--steps")) if given else (QUICK_STEPS if quick else STEPS)
    if given and quick:
        raise UsageError("--steps and --quick: give one (--quick is --steps 0.001)")
    for dt in dts:
        if dt > 0.01:
            raise UsageError(f"--steps: {dt:g} s is coarser than the boxes can be stepped (at most 0.01 s)")
        if dt < 1e-5:
            raise UsageError(f"--steps: {dt:g} s is finer than 1e-05 s (a million steps of the benchmark's 10 s, "
                             "each kept in memory)")
    md = markdown_and_json(out, json)
    if md is not None:
        check_output_file(md.parent / FIGURE, "--out (its figure, beside it)", suffixes=(".png",))
    n = workers or os.cpu_count() or 1
    with worker_pool(n, warm=("xcheck.league.run", "mujoco")) if n > 1 else nullcontext() as pool:
        rows = run_league(dts, pool=pool, progress=ctx.progress())
    for case in ("complex", "simple"):
        head, body = table_rows(rows, case, dts)
        ctx.say(f"\nboxes, {case} case")
        widths = [max(len(h), *(len(r[k]) for r in body)) for k, h in enumerate(head)]
        ctx.say("  ".join(h.ljust(w) for h, w in zip(head, widths)))
        for r in body:
            ctx.say("  ".join(c.ljust(w) for c, w in zip(r, widths)))
    failed = [c for c in checks(rows) if not c[1]]
    for what, _, why in failed:
        ctx.say(f"FAILED {what}: {why}")
    v = versions()
    if md is not None:  # everything made first, then written together: all of it or none
        file, _, png = draw(rows, dts)
        command = "xcheck league" + (" --quick" if quick else "") + (f" --steps {steps}" if steps else "")
        engines = sorted({r["engine"] for r in rows} - {"mujoco", "xcheck"})  # the live engines' releases too
        text = markdown(rows, dts, version=v["xcheck"], versions={k: v[k] for k in ("mujoco", *engines, "numpy", "scipy")},
                        command=f"{command} --out {md.name}")
    with signals_deferred():
        if json:
            write_json_atomic(json, {"schema": "xcheck.league/1", "versions": v, "steps": list(dts), "rows": rows})
            ctx.written.append(json)
        if md is not None:
            write_bytes_atomic(md.parent / file, png)
            write_text_atomic(md, text + f"\n![{file}]({file})\n")
            ctx.written.append(md)
    if md is not None:
        ctx.say(f"league table: {md} (figure {md.parent / file})")
    return TableOutcome("FAILED" if failed else "PASSED", rows)


def releases(*, scenarios: list[str], mujoco: str | None, out: str | None, json: str | None, bisect: bool,
             ctx: Context) -> TableOutcome:
    """Every MuJoCo release (or ``mujoco``'s) on the bundled scenarios and the boxes: the release table, or a
    bisection for the first release whose free-body RK4 is fourth order."""
    from ..base.files import write_json_atomic, write_text_atomic
    from ..league import releases as R

    versions = releases_arg(mujoco, ctx) if mujoco is not None else list(R.RELEASES)
    md = markdown_and_json(out, json)
    if bisect:
        if md is not None:
            raise UsageError("--out: a bisection probes only some releases; run without --bisect for the table")

        def good(v):
            try:
                return R.is_fourth_order(R.run_probe(v, scenarios=[R.PROBE_SCENARIO]))
            except R.ReleaseError as exc:
                raise UsageError(str(exc)) from None

        first, seen = R.bisect(versions, good)
        probed = ", ".join(f"{v} {'4th' if ok else 'not 4th'}"
                           for v, ok in sorted(seen.items(), key=lambda kv: R.release_key(kv[0])))
        ctx.say(f"free-body RK4 ({R.PROBE_SCENARIO}) fourth order from: "
                f"{first or f'none of {versions[0]} ... {versions[-1]}'} ({len(seen)} of {len(versions)} releases "
                f"probed: {probed})")
        if json:
            write_json_atomic(json, {"schema": "xcheck.releases-bisect/1", "first_fourth_order": first, "probed": seen})
        return TableOutcome("PASSED", seen)
    from ..scenario import resolve_scenario

    for name in scenarios:
        resolve_scenario(name)  # a bad name or file: said before any release is made
    probes, failures = {}, {}
    progress = ctx.progress()
    for k, v in enumerate(versions):
        progress(k, len(versions), f"MuJoCo {v}")
        try:
            probes[v] = R.run_probe(v, scenarios=scenarios or None, log=lambda *a: None)
        except R.ReleaseError as exc:
            failures[v] = str(exc).split(": ", 1)[-1]
            ctx.say(f"MuJoCo {v}: not run ({failures[v]})")
            continue
        d = probes[v]
        passed = sum(s["passed"] for s in d["scenarios"].values())
        order = R.rk4_order(d)
        ctx.say(f"MuJoCo {v}: {passed} of {len(d['scenarios'])} scenarios passed; free-body RK4 order "
                f"{'—' if order is None else f'{order:.2f}'}")
    progress(len(versions), len(versions), "")
    first = None  # the oldest probed release from which every probed release is fourth order
    for v in reversed([v for v in versions if v in probes]):
        if not R.is_fourth_order(probes[v]):
            break
        first = v
    ctx.say(f"free-body RK4 fourth order from: {first or 'none of these'}")
    if json:
        write_json_atomic(json, {"schema": "xcheck.releases/1", "probes": probes, "failures": failures,
                                 "first_fourth_order": first})
    if md is not None:
        command = ("xcheck releases" + (" " + " ".join(scenarios) if scenarios else "")
                   + (f" --mujoco {mujoco}" if mujoco else "") + f" --out {md.name}")
        write_text_atomic(md, R.markdown(probes, failures, version=__version__, command=command, first_good=first))
        ctx.say(f"release table: {md}")
    return TableOutcome("PASSED", probes)


def mjx(*, scenarios: list[str], out: str | None, json: str | None, methods: str | None, no_bench: bool,
        workers: int | None, ctx: Context) -> TableOutcome:
    """MJX in float32 and float64 on the bundled scenarios (or ``scenarios``), and its batched steps per second."""
    from ..base.files import write_json_atomic, write_text_atomic
    from ..engines import available

    if not available("mjx"):
        raise UsageError("mjx: MJX is not installed here: pip install 'xcheck[mjx]' (the PyPI packages mujoco-mjx "
                         "and jax)")
    md = markdown_and_json(out, json)
    from ..league.precision import floors, markdown, mjx_methods, run_precision_studies
    from ..scenario import resolve_scenario

    for name in scenarios:
        resolve_scenario(name)  # a bad name or file: said before any work
    chosen = None
    if methods is not None:
        chosen = csv_list(methods, str, "--methods")
        for m in chosen:
            if m not in mjx_methods():
                raise UsageError(f"--methods: {m!r} is not MJX's (expected some of {', '.join(mjx_methods())})")
    studies = run_precision_studies(scenarios or None, methods=chosen, workers=workers, progress=ctx.progress())
    rows = floors(studies)
    bench = []
    if not no_bench:
        from ..bench import run_bench

        bench = [r for r in run_bench(repeat=2, quick=True, methods=["mjx-rk4", "mjx-rk4-x64", "formulation-2",
                                                                     "lie-rkmk4", "mujoco-rk4"])
                 if r["batch"] > 1 or "mj_step" in r["method"] or r["method"].startswith("mjx")]
    width = max(len(r["scenario"]) for r in rows)
    for r in rows:
        if r["method"].startswith("mjx"):
            order = "—" if r["observed"] is None else f"{r['observed']:.2f}"
            floor = "—" if r["floor"] is None else f"{r['floor']:.2g}"
            ctx.say(f"{r['scenario']:<{width}}  {r['method']:<18} order {order:>5}  finest error {floor:>8} rad")
    for row in bench:
        ctx.say(f"{row['method']:<45} batch {row['batch']:>6}  {row['steps_per_second']:.3g} body-steps/s")
    if json:
        write_json_atomic(json, {"schema": "xcheck.mjx/1", "rows": rows, "bench": bench})
    if md is not None:
        from ..base.packages import package_version
        from ..versions import versions

        v = versions()
        command = ("xcheck mjx" + (" " + " ".join(scenarios) if scenarios else "")
                   + (f" --methods {methods}" if methods else "") + f" --out {md.name}")
        text = markdown(rows, bench, version=__version__, command=command,
                        versions={"mujoco": v["mujoco"], "mujoco-mjx": package_version("mujoco-mjx"),
                                  "jax": package_version("jax")})
        write_text_atomic(md, text)
        ctx.say(f"MJX table: {md}")
    return TableOutcome("PASSED", rows)
