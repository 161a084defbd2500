"""Where a cold start's time goes (issue 61): one xcheck command run in this process with an empty compile cache,
every numba compile recorded (numba's ``numba:compile`` events).

    python benchmarks/cold_start.py                                   # converge gyroscope-nonsingular --quick
    python benchmarks/cold_start.py report --quick --out /tmp/r       # any command line of xcheck's

It prints the command's wall time, the import of xcheck's command line, how many functions were compiled and the
seconds they took, grouped by the source file of each compiled function (its *own* time: a function's compile less the
compiles it triggered of the functions it calls), and the twenty costliest. The command runs with ``--workers 1`` where
it takes one, so that every compile happens here and is counted (a worker's would be its own process's); its wall time
is therefore one process's, not the two a user's run shares. The cache is a fresh temporary folder
(``XCHECK_CACHE_DIR``), removed at the end: nothing of the user's is touched. Nothing here is a test.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

DEFAULT = ["converge", "gyroscope-nonsingular", "--quick"]
#: The commands that take ``--workers`` (every compile then happens in this process).
TAKES_WORKERS = {"converge", "report", "horizon", "sweep", "nightly", "bench"}


def _own_times(buffer) -> list[tuple[str, str, float, float]]:
    """``(source file, function, own seconds, total seconds)`` per compile, from a recorder's buffer of
    ``(time, Event)``: a compile's own time is its total less the compiles nested in it."""
    out, stack = [], []
    for ts, event in buffer:
        if event.is_start:
            stack.append([ts, 0.0])
            continue
        start, nested = stack.pop()
        total = ts - start
        if stack:
            stack[-1][1] += total
        fn = event.data["dispatcher"].py_func
        source = Path(fn.__code__.co_filename)
        parts = source.parts
        where = "/".join(parts[parts.index("xcheck") + 1:]) if "xcheck" in parts else source.name
        out.append((where, fn.__qualname__, total - nested, total))
    return out


def main(argv=None) -> int:
    args = list(DEFAULT if not argv else argv)
    if args[0] in TAKES_WORKERS and "--workers" not in args:
        args += ["--workers", "1"]
    cache = Path(tempfile.mkdtemp(prefix="xcheck-cold-"))
    os.environ["XCHECK_CACHE_DIR"] = str(cache)
    try:
        t0 = time.perf_counter()
        from numba.core import event

        from xcheck.cli import main as xcheck_main

        imported = time.perf_counter() - t0
        with event.install_recorder("numba:compile") as rec:
            t1 = time.perf_counter()
            code = xcheck_main(args)
            wall = time.perf_counter() - t1
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    compiles = _own_times(rec.buffer)
    groups = defaultdict(lambda: [0, 0.0])
    for where, _, own, _ in compiles:
        groups[where][0] += 1
        groups[where][1] += own
    spent = sum(own for _, _, own, _ in compiles)
    print(f"\nxcheck {' '.join(args)}: exit {code}, {wall:.1f} s (the command line imported in {imported:.2f} s)")
    print(f"compiled: {len(compiles)} functions, {spent:.1f} s ({100 * spent / wall:.0f} % of the command's wall time)")
    print(f"\n| source | functions | own compile [s] |\n| --- | ---: | ---: |")
    for where, (n, s) in sorted(groups.items(), key=lambda kv: -kv[1][1]):
        print(f"| {where} | {n} | {s:.2f} |")
    print(f"\n| the costliest | source | own [s] | with what it compiled [s] |\n| --- | --- | ---: | ---: |")
    for where, name, own, total in sorted(compiles, key=lambda c: -c[2])[:20]:
        print(f"| {name} | {where} | {own:.2f} | {total:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
