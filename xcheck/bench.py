"""``xcheck bench``: steps per second of every method of the cross-check, ours and every engine's, measured in
the same run on the same bodies, so that ratios between them mean something on a shared, noisy machine.

Rows come from the runner registry (:data:`xcheck.runners.RUNNERS`): every runner on two bundled scenarios,
``gyroscope-nonsingular`` (torque free) and ``rax1-orbit-field`` (an attitude-dependent torque, evaluated at
every stage), for ``duration`` s at dt = 1/1024 s, through the same ``runner.run(context, dt)`` a study
calls; a runner with a batch path (``run_batch``) also on 10 000 perturbed gyroscopes at once, 100 steps each
(body-steps per second). An engine module may add rows of its own (``bench_extras``: MuJoCo's bare
``mj_step`` loop). Sweep cells per second (``xcheck sweep``'s unit of work, rows with ``cells_per_second``):
a chunk of 10 torque-free gyroscope cells from random attitudes, one step dt = 1/1024 s, each a whole cell
(model, exact reference, run, errors), ``lie-rkmk4`` batched and ``mujoco-rk4`` one cell at a time. Static
attitude determination (rows with ``solutions_per_second``): 100 000 random two-observation problems solved in
one call by each method of :mod:`xcheck.determination.methods`.
``--json PATH`` writes ``{"schema": "xcheck.bench/1", "versions": ..., "results": [...]}``
with rows ``{engine, method, scenario, batch, steps_per_second}``. For an adaptive method (``scipy-rk45``) a
"step" is a point of the output grid: the figure is how fast it delivers the same trajectory.

Compilation and loading are done before timing; each figure is the best of ``repeat`` runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import sys
import time

import numpy as np

from .versions import versions

#: The bundled scenarios timed: torque free, and an attitude-dependent torque.
BENCH_SCENARIOS = ("gyroscope-nonsingular", "rax1-orbit-field")
DT = 1 / 1024


def _best(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def run_bench(*, repeat: int = 3, batch: int = 10_000, quick: bool = False, methods=None,
              progress=None) -> list[dict]:
    """Measure and return the rows (see the module docstring) of ``methods`` (default: every runner)."""
    from .engines import ENGINES, asked_for
    from .runners import RUNNERS
    from .scenario import resolve_scenario
    from .study.context import run_context

    duration = 2.0 if quick else 10.0
    nsteps = round(duration / DT)
    batch = min(batch, 1000) if quick else batch
    runners = [RUNNERS[m] for m in methods] if methods else [r for r in RUNNERS.values()
                                                              if not r.opt_in or asked_for(r.engine)]
    contexts = {name: dataclasses.replace(run_context(resolve_scenario(name)), duration=duration)
                for name in BENCH_SCENARIOS}
    rows = []

    def add(engine, method, scenario, n, seconds, steps):
        rows.append({"engine": engine, "method": method, "scenario": scenario, "batch": n,
                     "steps_per_second": float(n * steps / seconds)})
        if progress:
            progress(rows[-1])

    for runner in runners:
        for scenario, ctx in contexts.items():
            runner.run(dataclasses.replace(ctx, duration=4 * DT), DT)  # compile and load outside the timing
            add(runner.engine, runner.name, scenario, 1, _best(lambda: runner.run(ctx, DT), repeat), nsteps)
    gyro = dataclasses.replace(contexts["gyroscope-nonsingular"], duration=1.0)
    rng = np.random.default_rng(0)
    Q = np.tile(gyro.q0, (batch, 1))
    W = gyro.omega0 + rng.normal(0.0, 0.01, (batch, 3))
    for runner in runners:
        if runner.run_batch is None:
            continue
        runner.run_batch(dataclasses.replace(gyro, duration=0.02), Q[:2], W[:2], 0.01)
        add(runner.engine, runner.name, "gyroscope-nonsingular", batch,
            _best(lambda: runner.run_batch(gyro, Q, W, 0.01), repeat), 100)
    for name in ("lie-rkmk4", "mujoco-rk4"):
        if any(r.name == name for r in runners):
            cells, seconds = _sweep_cells(name, duration, repeat)
            rows.append({"engine": RUNNERS[name].engine, "method": f"{name} (sweep cells)",
                         "scenario": "gyroscope-nonsingular", "batch": cells, "steps_per_second": cells * nsteps / seconds,
                         "cells_per_second": cells / seconds})
            if progress:
                progress(rows[-1])
    if not methods:
        for row in _determination_rows(10_000 if quick else 100_000, repeat):
            rows.append(row)
            if progress:
                progress(row)
    for engine in ENGINES.values():
        if not any(r.engine == engine.name for r in runners):
            continue
        extras = getattr(importlib.import_module(engine.module), "bench_extras", None)
        for method, scenario, seconds, steps, *batch in (extras(contexts, DT, nsteps, repeat) if extras else ()):
            add(engine.name, method, scenario, batch[0] if batch else 1, seconds, steps)
    return rows


def _sweep_cells(method: str, duration: float, repeat: int, cells: int = 10) -> tuple[int, float]:
    """(cells, best seconds) of :func:`xcheck.sweep.run.run_chunk` on ``cells`` torque-free gyroscope cells at
    one step; the per-process caches of contexts and references are cleared before each timing, so that every
    cell pays for its model and reference as in a sweep."""
    from .scenario import resolve_scenario
    from .study import context
    from .sweep.run import run_chunk
    from .sweep.spec import apply_cell, random_quaternions

    base = dataclasses.replace(resolve_scenario("gyroscope-nonsingular"), duration=duration)
    q = random_quaternions(cells, np.random.default_rng(0))
    chunk = [(str(i), {}, apply_cell(base, {"attitude": q[i].tolist()})) for i in range(cells)]
    run_chunk(chunk[:2], [method], (DT,))  # compile and load outside the timing

    def once():
        context._CACHE.clear()
        run_chunk(chunk, [method], (DT,))
    return cells, _best(once, repeat)


def _determination_rows(n: int, repeat: int) -> list[dict]:
    """Static attitude determination (:mod:`xcheck.determination.methods`): ``n`` random two-observation problems
    (noisy directions of random attitudes) solved in one call per method; a "step" is one solution."""
    from .determination.methods import METHODS
    from .rotations import quat_to_dcm

    rng = np.random.default_rng(0)
    q = rng.standard_normal((n, 4))
    r = rng.standard_normal((n, 2, 3))
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    b = np.einsum("nji,nkj->nki", quat_to_dcm(q), r) + 1e-3 * rng.standard_normal((n, 2, 3))
    w = np.array([0.5, 0.5])
    rows = []
    for name, solve in METHODS.items():
        solve(b[:2], r[:2], w)  # compiled code loaded before the timing
        seconds = _best(lambda: solve(b, r, w), repeat)
        rows.append({"engine": "xcheck", "method": f"{name} (determination)", "scenario": "random 2-vector problems",
                     "batch": n, "steps_per_second": n / seconds, "solutions_per_second": n / seconds})
    return rows


def fastest_mujoco_rk4(rows, scenario: str = "gyroscope-nonsingular") -> dict | None:
    """MuJoCo's fastest single-trajectory RK4 row of ``scenario`` (its ``rollout`` through the runner, or its bare
    ``mj_step`` loop): a ratio against MuJoCo is honest only against the best it does."""
    mj = [r for r in rows if r["engine"] == "mujoco" and r["batch"] == 1 and r["scenario"] == scenario
          and r["method"].startswith("mujoco-rk4") and "cells_per_second" not in r]
    return max(mj, key=lambda r: r["steps_per_second"]) if mj else None


def ratio_lines(rows, scenario: str = "gyroscope-nonsingular") -> list[str]:
    """Each other single-trajectory RK4-family row of ``scenario`` against :func:`fastest_mujoco_rk4`."""
    best = fastest_mujoco_rk4(rows, scenario)
    if best is None:
        return []
    out = [f"against MuJoCo's fastest RK4 row on {scenario}, {best['method']} ({best['steps_per_second']:.3g} "
           "steps/s):"]
    for r in rows:
        if r["batch"] == 1 and r["scenario"] == scenario and r["engine"] != "mujoco" and "solutions_per_second" not in r:
            out.append(f"  {r['method']:28s} {r['steps_per_second'] / best['steps_per_second']:6.1f}x")
    return out


def format_rows(rows) -> str:
    lines = [f"{'engine':8s} {'method':28s} {'scenario':24s} {'batch':>6s} {'steps/s':>10s}"]
    for r in rows:
        cells = (f"  ({r['cells_per_second']:.1f} cells/s)" if "cells_per_second" in r else
                 "  (solutions/s)" if "solutions_per_second" in r else "")
        lines.append(f"{r['engine']:8s} {r['method']:28s} {r['scenario']:24s} {r['batch']:6d} "
                     f"{r['steps_per_second']:10.3g}{cells}")
    return "\n".join(lines + [""] + ratio_lines(rows))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="xcheck bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", metavar="PATH", help="write the results as JSON (schema xcheck.bench/1)")
    parser.add_argument("--quick", action="store_true", help="shorter runs, smaller batch")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs (default 3)")
    parser.add_argument("--methods", help="comma-separated methods (default: every method)")
    args = parser.parse_args(argv)
    rows = run_bench(repeat=max(1, args.repeat), quick=args.quick,
                     methods=args.methods.split(",") if args.methods else None,
                     progress=(lambda r: print(f"  {r['engine']} {r['method']} {r['scenario']} batch={r['batch']}: "
                                               f"{r['steps_per_second']:.3g} steps/s", file=sys.stderr))
                     if sys.stderr.isatty() else None)
    print(format_rows(rows))
    if args.json:
        from .base.files import write_json_atomic

        write_json_atomic(args.json, {"schema": "xcheck.bench/1", "versions": versions(), "results": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
