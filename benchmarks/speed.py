"""The speed figures of issue 10, measured the way a user meets them, against their goals.

    python benchmarks/speed.py              # ~2 minutes: reports, converge, folder sizes, bench ratios
    python benchmarks/speed.py --fresh      # also README lines 1 and 2 in a fresh clone (~6 minutes)

Wall times are the best of several runs (these machines are shared and noisy); speeds are ratios within one
``xcheck bench`` run. Nothing here is a test: the figures are printed, and docs/architecture.md keeps the
latest. Run it from a checkout with xcheck installed (the ``xcheck`` of the current environment is timed).
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


def best_of(n, argv, **kwargs) -> float:
    best = float("inf")
    for _ in range(n):
        t0 = time.perf_counter()
        proc = subprocess.run(argv, capture_output=True, text=True, **kwargs)
        elapsed = time.perf_counter() - t0
        if proc.returncode not in (0, 1):
            sys.exit(f"{' '.join(map(str, argv))} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
        best = min(best, elapsed)
    return best


def folder_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def bench_ratios(tmp: Path) -> list[tuple[str, float, str, bool]]:
    out = tmp / "bench.json"
    subprocess.run([*XCHECK, "bench", "--json", str(out)], check=True, capture_output=True)
    rows = json.loads(out.read_text())["results"]
    single = {(r["method"], r["scenario"]): r["steps_per_second"] for r in rows if r["batch"] == 1}
    batch = {r["method"]: r["steps_per_second"] for r in rows if r["batch"] > 1}
    mujoco = single[("mujoco-rk4", "gyroscope-nonsingular")]
    lines = []
    for method in ("euler-rk4", "formulation-1", "formulation-2", "lie-rkmk4", "lie-cf4", "dcm-rk4", "gibbs-rk4",
                   "rotvec-rk4"):
        ratio = single[(method, "gyroscope-nonsingular")] / mujoco
        lines.append((f"own single trajectory / MuJoCo RK4: {method}", ratio, ">= 10x", ratio >= 10))
    for method in ("formulation-2", "lie-rkmk4"):
        lines.append((f"own batch N = 10 000, body-steps/s: {method}", batch[method], ">= 1.5e7", batch[method] >= 1.5e7))
    return lines


def fresh_clone(tmp: Path) -> list[tuple[str, float, str, bool]]:
    """README lines 1 and 2, in order, in a fresh clone with an empty compile cache (as a newcomer runs them)."""
    readme = (ROOT / "README.md").read_text().splitlines()
    commands = [line.strip() for line in readme if line.strip().startswith(("python3 -m venv", "python -m venv"))][:2]
    clone = tmp / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    env = {**os.environ, "XCHECK_CACHE_DIR": str(tmp / "cache")}
    env.pop("VIRTUAL_ENV", None)
    lines = []
    for k, (command, goal) in enumerate(zip(commands, (60.0, 150.0)), start=1):
        t0 = time.perf_counter()
        proc = subprocess.run(["bash", "-c", command], cwd=clone, env=env, capture_output=True, text=True)
        elapsed = time.perf_counter() - t0
        if proc.returncode != 0:
            sys.exit(f"README line {k} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        lines.append((f"README line {k} on a fresh clone [s]", elapsed, f"<= {goal:g}", elapsed <= goal))
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fresh", action="store_true", help="also time README lines 1 and 2 in a fresh clone")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs (default 3)")
    args = parser.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="xcheck-speed-"))
    try:
        lines = []
        subprocess.run([*XCHECK, "report", "--quick", "--out", str(tmp / "warm")], capture_output=True)  # warm
        t = best_of(args.repeat, [*XCHECK, "report", "--quick", "--out", str(tmp / "q")])
        lines.append(("xcheck report --quick [s]", t, "<= 5", t <= 5))
        t = best_of(max(1, args.repeat - 1), [*XCHECK, "report", "--out", str(tmp / "f")])
        lines.append(("xcheck report (full) [s]", t, "<= 15", t <= 15))
        for name in ("gyroscope-nonsingular", "rax1-orbit-field", "tumbler-intermediate-axis"):
            t = best_of(args.repeat, [*XCHECK, "converge", name, "--quick"])
            lines.append((f"xcheck converge {name} --quick [s]", t, "<= 1.5", t <= 1.5))
        for kind, folder in (("quick", tmp / "q"), ("full", tmp / "f")):
            size = folder_size((folder / "latest").resolve()) / 1e6
            lines.append((f"size of one {kind} report folder [MB]", size, "<= 5", size <= 5))
        lines += bench_ratios(tmp)
        if args.fresh:
            lines += fresh_clone(tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    width = max(len(w) for w, *_ in lines)
    for what, value, goal, met in lines:
        print(f"{what:{width}s}  {value:10.3g}  {goal:>9s}  {'met' if met else 'NOT MET'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
