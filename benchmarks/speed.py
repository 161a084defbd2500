"""The speed goals (issues 10, 23 and 41), measured the way a user meets them, each with and without Basilisk.

    python benchmarks/speed.py              # ~6 minutes: reports, converge, bench ratios, with and without Basilisk
    python benchmarks/speed.py --suite      # also the test suite (the README's pytest command), both ways
    python benchmarks/speed.py --fresh      # only the newcomer's three rows (issue 61): README lines 1 and 2 on a
                                            # fresh clone, and a converge with an empty compile cache (~10 minutes)

"Without Basilisk" is the same environment with ``XCHECK_WITHOUT=basilisk`` (xcheck then leaves the installed
engine out, as on a machine without it). Wall times are the best of several runs (these machines are shared and
noisy); speeds are ratios within one ``xcheck bench`` run, against MuJoCo's fastest row of that run (its bare
``mj_step`` loop or its ``rollout``, whichever is faster; the table says which). Nothing here is a test: the
figures are printed, and docs/architecture.md keeps the latest. Run it from a checkout with xcheck installed
(the ``xcheck`` of the current environment is timed).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
XCHECK = [sys.executable, "-m", "xcheck"]
WITHOUT = {"XCHECK_WITHOUT": "basilisk"}
#: Our RK4 methods and the ratio to MuJoCo's fastest single-trajectory row each must reach.
SINGLE_GOALS = {"euler-rk4": 10, "formulation-1": 20, "formulation-2": 20, "lie-rkmk4": 20, "lie-cf4": 20,
                "dcm-rk4": 10, "gibbs-rk4": 10, "rotvec-rk4": 10, "mrp-rk4": 20}
#: The bundled scenarios when issue 23 set its report goals (issue 27 added the tops and the CubeSat of parts).
ISSUE_23_SCENARIOS = ("gyroscope-near-singular", "gyroscope-nonsingular", "gyroscope-singular", "rax1-body-field",
                      "rax1-orbit-field", "tumbler-intermediate-axis")
#: Batch (N = 10 000) body-steps per second each must reach.
BATCH_GOALS = {"formulation-2": 3e7, "lie-rkmk4": 2e7}


def basilisk_installed() -> bool:
    import importlib.util

    return importlib.util.find_spec("Basilisk") is not None


def best_of(n, argv, env=None, **kwargs) -> float:
    best = float("inf")
    for _ in range(n):
        t0 = time.perf_counter()
        proc = subprocess.run(argv, capture_output=True, text=True, env={**os.environ, **(env or {})}, **kwargs)
        elapsed = time.perf_counter() - t0
        if proc.returncode not in (0, 1):
            sys.exit(f"{' '.join(map(str, argv))} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
        best = min(best, elapsed)
    return best


def folder_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def bench_lines(tmp: Path) -> list[tuple[str, float, str, bool]]:
    """Single-trajectory ratios against MuJoCo's fastest row, and batch body-steps/s, from one ``xcheck bench``."""
    out = tmp / "bench.json"
    subprocess.run([*XCHECK, "bench", "--json", str(out)], check=True, capture_output=True,
                   env={**os.environ, **WITHOUT})  # Basilisk's rows are not in these goals
    from xcheck.bench import fastest_mujoco_rk4

    rows = json.loads(out.read_text())["results"]
    single = {(r["method"], r["scenario"]): r["steps_per_second"] for r in rows if r["batch"] == 1}
    batch = {r["method"]: r["steps_per_second"] for r in rows if r["batch"] > 1 and "cells_per_second" not in r}
    fastest = fastest_mujoco_rk4(rows)
    lines = [(f"MuJoCo's fastest RK4 row: {fastest['method']} [steps/s]", fastest["steps_per_second"], "", True)]
    for method, goal in SINGLE_GOALS.items():
        ratio = single[(method, "gyroscope-nonsingular")] / fastest["steps_per_second"]
        lines.append((f"own single trajectory / MuJoCo's fastest: {method}", ratio, f">= {goal}x", ratio >= goal))
    for method, goal in BATCH_GOALS.items():
        lines.append((f"own batch N = 10 000, body-steps/s: {method}", batch[method], f">= {goal:.0e}",
                      batch[method] >= goal))
    return lines


GUARD_PROBE = """
import time, warnings
warnings.simplefilter("ignore")
from xcheck.guard import check_exact, guard_times
from xcheck.scenario import bundled_scenarios, resolve_scenario
from xcheck.study.context import run_context
cases = []
for name in bundled_scenarios():
    sc = resolve_scenario(name)
    if sc.reference == "exact":
        ctx = run_context(sc)
        cases.append((ctx, guard_times(ctx.duration, (*sc.steps, *sc.quick_steps, sc.adaptive_step))))
check_exact(cases[0][0].inertia, cases[0][0].q0, cases[0][0].omega0, 1.0, cases[0][0].torque)  # load the kernels
best = float("inf")
for _ in range(5):
    t0 = time.perf_counter()
    for ctx, times in cases:
        check_exact(ctx.inertia, ctx.q0, ctx.omega0, ctx.duration, ctx.torque, times)
    best = min(best, time.perf_counter() - t0)
print(len(cases), best)
"""


def score_lines(tmp: Path, repeat: int) -> list[tuple[str, float, str, bool]]:
    """Issue 39: ``xcheck score`` of a million-row file (the tumbler's exact motion written scalar-last, so that it
    fails and the detective runs too: the worst case), as a user runs it."""
    import numpy as np

    from xcheck.scenario import resolve_scenario
    from xcheck.study.context import scenario_reference

    sc = resolve_scenario("tumbler-intermediate-axis")
    t = np.linspace(0.0, sc.duration, 1_000_000)
    q, w, _ = scenario_reference(sc).at(t)
    path = tmp / "million.csv"
    np.savetxt(path, np.column_stack([t, q[:, [1, 2, 3, 0]], w]), delimiter=",", fmt="%.17g", comments="",
               header="t_s,qw,qx,qy,qz,wx_rad_s,wy_rad_s,wz_rad_s")
    elapsed = best_of(repeat, [*XCHECK, "score", str(path), "--scenario", sc.name])  # exit 1: it fails
    return [("xcheck score of a 1e6-row file (the detective included) [s]", elapsed, "<= 5", elapsed <= 5)]


#: Issue 41: a day of RAX-1 in the orbit field at 0.1 s (864 000 steps) by each of these, the best of 3 after a warm run
DAY_METHODS = ("formulation-2", "lie-rkmk4", "lie-lgvi", "split-strang")
DAY_PROBE = """
import sys, time
from xcheck.integrators import integrate
from xcheck.scenario import resolve_scenario
from xcheck.study.context import run_context
ctx = run_context(resolve_scenario("rax1-orbit-field"))
for method in sys.argv[1:]:
    integrate(method, ctx.inertia, ctx.q0, ctx.omega0, dt=0.1, duration=10.0, torque=ctx.torque)  # compiled, loaded
    best = 1e9
    for _ in range(3):
        t0 = time.perf_counter()
        traj = integrate(method, ctx.inertia, ctx.q0, ctx.omega0, dt=0.1, duration=86400.0, torque=ctx.torque)
        best = min(best, time.perf_counter() - t0)
    assert traj.ok and len(traj.t) == 864001, traj.message
    print(method, best)
import dataclasses
from xcheck.study.horizon import _Compiled
long = dataclasses.replace(resolve_scenario("rax1-field-gravity-gradient"), duration=86400.0)
ctx = run_context(long)
best = 1e9
for _ in range(3):
    t0 = time.perf_counter()
    _Compiled(ctx, 86400.0)  # the compiled DOP853 at rtol 2.5e-15 and its check at half the tolerance
    best = min(best, time.perf_counter() - t0)
print("reference", best)
"""


def horizon_lines(tmp: Path) -> list[tuple[str, float, str, bool]]:
    """Issue 41: a day of RAX-1 at 0.1 s for one of our methods (< 0.5 s), the reference over a day (< 10 s), and
    ``xcheck horizon`` of the bundled gyroscope's hour (every method installed, the engines within their step budget,
    at its three steps: < 60 s on two cores)."""
    out = subprocess.run([sys.executable, "-c", DAY_PROBE, *DAY_METHODS], check=True, capture_output=True,
                         text=True).stdout.split("\n")
    lines = []
    for row in filter(None, out):
        method, seconds = row.split()
        if method == "reference":
            lines.append(("the reference over a day: RAX-1 in the field and the gravity gradient, the compiled DOP853 "
                          "checked at half its tolerance [s]", float(seconds), "<= 10", float(seconds) <= 10))
            continue
        lines.append((f"a day of RAX-1 in the orbit field at 0.1 s [s]: {method}", float(seconds), "<= 0.5",
                      float(seconds) <= 0.5))
    t = best_of(1, [*XCHECK, "horizon", "gyroscope-nonsingular", "--json", str(tmp / "horizon.json")])
    lines.append(("xcheck horizon gyroscope-nonsingular (an hour; every method, engines included, three steps) [s]", t,
                  "<= 60", t <= 60))
    return lines


def guard_seconds() -> tuple[int, float]:
    """Issue 36's guard: ``check_exact`` on every bundled scenario with an exact reference, the best of 5 [s]."""
    out = subprocess.run([sys.executable, "-c", GUARD_PROBE], check=True, capture_output=True, text=True).stdout.split()
    return int(out[0]), float(out[1])


def suite(env) -> float:
    """The README's test command's pytest part, in this environment."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "auto", "--dist", "loadfile", "-p",
                           "no:cacheprovider"], cwd=ROOT, capture_output=True, text=True, env={**os.environ, **env})
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"the test suite failed:\n{proc.stdout[-3000:]}")
    return elapsed


def fresh_clone(tmp: Path):
    """README lines 1 and 2, in order, in a fresh clone with an empty compile cache (as a newcomer runs them): each
    row as its line ends."""
    readme = (ROOT / "README.md").read_text().splitlines()
    commands = [line.strip() for line in readme if line.strip().startswith(("python3 -m venv", "python -m venv"))][:2]
    clone = tmp / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    env = {**os.environ, "XCHECK_CACHE_DIR": str(tmp / "cache")}
    env.pop("VIRTUAL_ENV", None)
    for k, (command, goal) in enumerate(zip(commands, (60.0, 150.0)), start=1):
        t0 = time.perf_counter()
        proc = subprocess.run(["bash", "-c", command], cwd=clone, env=env, capture_output=True, text=True)
        elapsed = time.perf_counter() - t0
        if proc.returncode != 0:
            sys.exit(f"README line {k} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        yield f"README line {k} on a fresh clone [s]", elapsed, f"<= {goal:g}", elapsed <= goal


def cold_converge(tmp: Path, repeat: int) -> list[tuple[str, float, str, bool]]:
    """``xcheck converge gyroscope-nonsingular --quick`` as on a machine that never ran xcheck: each run with a
    compile cache of its own, empty (``XCHECK_CACHE_DIR``); the best of ``repeat``. Where its time goes:
    benchmarks/cold_start.py."""
    best = float("inf")
    for k in range(repeat):
        cache = tmp / f"cold-{k}"
        best = min(best, best_of(1, [*XCHECK, "converge", "gyroscope-nonsingular", "--quick"],
                                 {"XCHECK_CACHE_DIR": str(cache)}))
        shutil.rmtree(cache, ignore_errors=True)
    return [("xcheck converge gyroscope-nonsingular --quick, empty compile cache [s]", best, "<= 10", best <= 10)]


WIDTH = 78  # the "what" column; a longer row widens its own line only


class Rows(list):
    """The table's rows, each printed as it is measured (a run cut short still shows what it measured): the header
    with the first row, then one line per row."""

    def append(self, row) -> None:
        if not self:
            print(f"| {'what':{WIDTH}s} | {'measured':>10s} | {'goal':>9s} |     |")
            print(f"| {'-' * WIDTH} | {'-' * 10}:| {'-' * 9}:| --- |")
        what, value, goal, met = row
        print(f"| {what:{WIDTH}s} | {value:10.3g} | {goal:>9s} | {'met' if met else 'NOT MET'} |", flush=True)
        super().append(row)

    def extend(self, rows) -> None:
        for row in rows:
            self.append(row)

    def __iadd__(self, rows):
        self.extend(rows)
        return self


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fresh", action="store_true", help="only the newcomer's rows: README lines 1 and 2 in a "
                        "fresh clone, and a converge with an empty compile cache")
    parser.add_argument("--suite", action="store_true", help="also time the test suite, with and without Basilisk")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs (default 3)")
    args = parser.parse_args(argv)
    ways = [("with Basilisk", {}), ("without", WITHOUT)] if basilisk_installed() else [("without Basilisk", {})]
    tmp = Path(tempfile.mkdtemp(prefix="xcheck-speed-"))
    if args.fresh:  # the newcomer's rows alone (issue 61)
        lines = Rows()
        try:
            lines += cold_converge(tmp, max(1, args.repeat - 1))
            lines += fresh_clone(tmp)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return 0
    lines = Rows()
    try:
        subprocess.run([*XCHECK, "report", "--quick", "--out", str(tmp / "warm")], capture_output=True)  # warm
        for way, env in ways:
            t = best_of(args.repeat, [*XCHECK, "report", "--quick", "--out", str(tmp / "q")], env)
            lines.append((f"xcheck report --quick [s], {way}", t, "<= 5", t <= 5))
        n, guard = guard_seconds()  # each worker process that runs a scenario's methods checks its reference once
        quick = next(v for w, v, *_ in lines if w.startswith("xcheck report --quick [s]"))
        share = 2 * guard / quick
        lines.append((f"the guard of {n} exact references, twice (both processes) / the quick report", share,
                      "<= 0.05", share <= 0.05))
        for way, env in ways:  # the goal was set on these six; issue 27 added four more scenarios
            t = best_of(args.repeat, [*XCHECK, "report", "--quick", "--out", str(tmp / "q6"), *ISSUE_23_SCENARIOS], env)
            lines.append((f"xcheck report --quick, issue 23's six scenarios [s], {way}", t, "<= 5", t <= 5))
        for way, env in ways:
            t = best_of(max(1, args.repeat - 1), [*XCHECK, "report", "--out", str(tmp / "f")], env)
            lines.append((f"xcheck report (full) [s], {way}", t, "<= 15", t <= 15))
        for way, env in ways:
            t = best_of(max(1, args.repeat - 1), [*XCHECK, "report", "--out", str(tmp / "f6"), *ISSUE_23_SCENARIOS],
                        env)
            lines.append((f"xcheck report (full), issue 23's six scenarios [s], {way}", t, "<= 15", t <= 15))
        for name in ("gyroscope-nonsingular", "rax1-orbit-field", "tumbler-intermediate-axis"):
            for way, env in ways:
                t = best_of(args.repeat, [*XCHECK, "converge", name, "--quick"], env)
                lines.append((f"xcheck converge {name} --quick [s], {way}", t, "<= 1.5", t <= 1.5))
        for kind, folder in (("quick", tmp / "q"), ("full", tmp / "f")):
            size = folder_size((folder / "latest").resolve()) / 1e6
            lines.append((f"size of one {kind} report folder [MB]", size, "<= 5", size <= 5))
        lines += bench_lines(tmp)
        lines += score_lines(tmp, max(1, args.repeat - 1))
        lines += horizon_lines(tmp)
        if args.suite:
            for way, env in ways:
                t = suite(env)
                lines.append((f"the test suite, -n auto [s], {way}", t, "<= 120", t <= 120))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
