"""``xcheck sweep``: a model-swap sweep, every cell a cross-check (:mod:`xcheck.sweep.spec`, :mod:`xcheck.sweep.run`)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

from ..base.errors import UsageError
from . import Context, Outcome


@dataclass
class SweepRun:
    """What :func:`run_sweep` did: the folder written, every cell's record (spec order), how many cells ran now and
    how many came from an earlier run (``--resume``), and the timings (:class:`xcheck.sweep.run.Cells`)."""

    folder: Path
    records: list
    ran: int
    reused: int
    wall_time: float
    timings: dict


def run_sweep(spec, out_root, *, jobs: int = 1, resume: bool = False, kind: str = "local",
              scheduler: str | None = None, progress=None, say=print) -> SweepRun:
    """Every cell of ``spec`` not yet finished (:func:`xcheck.sweep.run.run_cells`), then the sweep's folder under
    ``out_root/<spec stem>/`` (:func:`xcheck.report.sweep.write_sweep`), the cells' log removed once it is written.
    Another run writing into the same folder: :class:`xcheck.base.files.BusyError`, before any work."""
    from ..base.files import held_alone
    from ..report.sweep import write_sweep
    from ..sweep.run import run_cells

    t_start = time.perf_counter()
    root = Path(out_root) / spec.path.stem
    root.mkdir(parents=True, exist_ok=True)
    with held_alone(root, "--out"):  # one run at a time into a sweep's folder: its live log is no interrupted run's
        cells = run_cells(spec, root, jobs=jobs, resume=resume, kind=kind, scheduler=scheduler, progress=progress,
                          say=say)
        folder = write_sweep(spec, cells.records, root, methods=cells.methods, timings=cells.timings, ran=cells.ran,
                             reused=cells.reused, wall_time=time.perf_counter() - t_start, log=cells.log)
        cells.log.unlink(missing_ok=True)
    return SweepRun(folder=folder, records=cells.records, ran=cells.ran, reused=cells.reused,
                    wall_time=time.perf_counter() - t_start, timings=cells.timings)


@dataclass
class SweepOutcome(Outcome):
    sweep: SweepRun


def sweep(*, spec: str, out: str, jobs: int | None, resume: bool, max_cells: int | None, executor: str,
          scheduler: str | None, ctx: Context) -> SweepOutcome:
    """Every cell of the sweep ``spec`` not yet done, into ``out/<spec name>/<stamp>/``."""
    from ..base.files import check_output_dir
    from ..results import outcome_of
    from ..sweep.run import PARTIAL_LOG
    from ..sweep.spec import MAX_CELLS, resolve_sweep

    if jobs is not None and jobs < 1:
        raise UsageError(f"--jobs: expected a positive number of processes, got {jobs}")
    if scheduler and executor != "dask":
        raise UsageError("--scheduler: only with --executor dask")
    if max_cells is not None and max_cells < 1:
        raise UsageError(f"--max-cells: expected a positive number of cells, got {max_cells}")
    sp = resolve_sweep(spec, max_cells=MAX_CELLS if max_cells is None else max_cells)
    check_output_dir(out, "--out")
    cpus = os.cpu_count() or 1
    n_jobs = min(jobs or cpus, cpus)
    if jobs and jobs > n_jobs:
        ctx.say(f"note: --jobs {jobs}: {n_jobs} worker processes, one per CPU (more would only share them)")
    n = len(sp.cells)
    ctx.say(f"sweep {sp.path.stem}: {n} cell{'s' * (n != 1)} x {len(sp.steps)} steps, base {sp.base.name}, on "
            f"{'a Dask cluster' if executor == 'dask' else f'{n_jobs} process' + 'es' * (n_jobs > 1)}")
    try:
        done = run_sweep(sp, out, jobs=n_jobs, resume=resume, kind=executor, scheduler=scheduler,
                         progress=ctx.progress())
    except KeyboardInterrupt:
        log = Path(out) / sp.path.stem / PARTIAL_LOG
        if log.exists():
            ctx.note(f"\nxcheck: the cells finished so far are kept in {log}; run again with --resume to skip them")
        raise
    passed = sum(r["passed"] for r in done.records)
    t = done.timings
    if done.ran:
        ctx.say(f"{done.ran} cells in {done.wall_time:.1f} s: {t['cells_per_second']:.2f} cells/s; start-up "
                f"{t['executor_start']:.2f} s; per cell (median): model and torque {1e3 * t['context']:.1f} ms, "
                f"reference {1e3 * t['reference']:.1f} ms, compute {1e3 * t['compute']:.1f} ms")
    if done.reused:
        ctx.say(f"{done.reused} cells from the earlier run (--resume)")
    outcome = outcome_of(r.get("outcome") or ("PASSED" if r["passed"] else "FAILED") for r in done.records)
    undecided = sum(r.get("outcome") == "INCONCLUSIVE" for r in done.records)
    ctx.say(f"sweep: {done.folder}/index.html; {passed} of {n} cells passed every check"
            + (f", {undecided} inconclusive" if undecided else ""))
    return SweepOutcome(outcome, done)
