"""Running a sweep (issue 12): every cell a cross-check, in chunks on an executor, logged as it finishes.

Data flow::

    load_sweep(spec) -> cells -> plan_chunks: cells that differ only in initial state or inertia (same model,
    torque, duration) go together -> run_chunk, in a worker: our batch methods through integrate_batch in one
    call per step, the others one run at a time; one record per cell (the study's metrics, orders, checks)
    -> the log, one JSON line per cell, flushed and synced per chunk (what --resume reads)
    -> when every cell is in: the tidy table (CSV), the database (the history's schema), figures, index.html,
    written into a hidden folder and renamed into place (:mod:`xcheck.report.sweep`).

The executor is this process (``--jobs 1``), a pool of worker processes (``--jobs N``), or a Dask cluster
(``--executor dask``): the same chunks and the same functions, so the results are the same; only the
wall times differ. Nothing here imports MuJoCo or matplotlib: the engine is imported by the runs that need it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import time
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base.executors import executor
from ..runners import RUNNERS
from .spec import SweepError, SweepSpec, apply_cell, cell_id

__all__ = ["SweepLog", "plan_chunks", "run_chunk", "run_cells", "sweep_methods", "fingerprint", "executor", "CHUNK",
           "LOG_SCHEMA"]

LOG_SCHEMA = "xcheck.sweep-log/1"
#: Cells per task, at most: enough to amortise a task's overhead and fill a batch, few enough that an interrupted
#: sweep loses little; a small sweep is cut finer (at least :data:`MIN_TASKS` tasks) so that every worker has work.
CHUNK = 10
MIN_TASKS = 4


def sweep_methods(spec: SweepSpec) -> list[str]:
    from ..study import default_methods

    return list(spec.methods) if spec.methods else default_methods(spec.base)


def fingerprint(spec: SweepSpec) -> str:
    """What a cell's result depends on besides its parameters: the base scenario's and its files' bytes, the
    methods and the steps. A log written under another fingerprint cannot be resumed."""
    h = hashlib.sha1()
    from ..torque_terms import torque_terms

    files = [spec.base.path, spec.base.model] + [v for term in torque_terms(spec.base.torque)
                                                 for k, v in term.items() if k == "table"]
    for f in files:
        h.update(Path(f).read_bytes())
    h.update(json.dumps({"methods": sweep_methods(spec), "steps": list(spec.steps)}).encode())
    return h.hexdigest()[:16]


# ------------------------------------------------------------------------------------------------------
# the log: one JSON line per finished cell, what --resume reads
# ------------------------------------------------------------------------------------------------------
class SweepLog:
    """The cells finished so far, in a JSON-lines file: a header line (schema, fingerprint), then one record per
    cell. Appended and synced per chunk; a line cut short by a kill is dropped when the log is read."""

    def __init__(self, path: Path, fp: str):
        self.path, self.fingerprint = Path(path), fp
        self.records: dict[str, dict] = {}

    def read(self, source: Path | None = None) -> int:
        """The records of an earlier run (``source``, default this log) whose fingerprint matches; a log of
        another base, methods or steps, or one that is damaged (a line that is not a cell's record), is a
        :class:`SweepError` naming the file and the line, and the file is left as it is. Returns how many were
        read."""
        source = Path(source or self.path)
        again = "remove it or run without --resume to start over"
        try:
            lines = source.read_bytes().decode("utf-8").splitlines()
        except OSError as exc:
            raise SweepError(f"{source}: cannot be read ({exc.strerror or exc}); {again}") from None
        except UnicodeDecodeError:
            raise SweepError(f"{source}: not an xcheck sweep log (not UTF-8 text); {again}") from None
        try:
            header = json.loads(lines[0]) if lines else {}
        except json.JSONDecodeError:
            header = {}
        if not isinstance(header, dict) or header.get("schema") != LOG_SCHEMA:
            raise SweepError(f"{source}: not an xcheck sweep log (its first line is not the header of schema "
                             f"{LOG_SCHEMA}); {again}")
        if header.get("fingerprint") != self.fingerprint:
            raise SweepError(f"{source}: written for another base scenario, model, methods or steps than the spec "
                             "now names; run without --resume to start over")
        records = {}
        for n, line in enumerate(lines[1:], start=2):
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                if n == len(lines):  # the last line of a killed writer
                    continue
                raise SweepError(f"{source}, line {n}: not JSON; {again}") from None
            problem = record_problem(rec)
            if problem:
                raise SweepError(f"{source}, line {n}: not a cell's record ({problem}); {again}")
            records[rec["id"]] = rec
        self.records.update(records)
        return len(self.records)

    def start(self) -> None:
        """Write the log afresh: its header and the records kept (atomic; appended to from then on)."""
        from ..base.files import write_text_atomic

        lines = [json.dumps({"schema": LOG_SCHEMA, "fingerprint": self.fingerprint})]
        lines += [json.dumps(r, allow_nan=False) for r in self.records.values()]
        write_text_atomic(self.path, "\n".join(lines) + "\n")

    def append(self, records: list[dict]) -> None:
        with open(self.path, "a", encoding="utf-8") as f:
            f.write("".join(json.dumps(r, allow_nan=False) + "\n" for r in records))
            f.flush()
            os.fsync(f.fileno())
        for r in records:
            self.records[r["id"]] = r


_NUMBERS = ("dt", "attitude_error", "max_attitude_error", "omega_error", "max_omega_error", "energy_change",
            "momentum_change", "momentum_turn", "norm_drift", "wall_time", "steps_per_second", "repeats", "evaluations",
            "rtol")


def _number(v) -> bool:
    return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))


def record_problem(rec) -> str | None:
    """What makes ``rec`` not a cell's record as :func:`_record` writes it (None: nothing): the shape the
    sweep's tables and figures read, and an id that is its parameters' digest."""
    if not isinstance(rec, dict):
        return f"a JSON {type(rec).__name__}, not an object"
    for key, kind in (("id", str), ("params", dict), ("passed", bool), ("methods", dict), ("checks", list),
                      ("timings", dict)):
        if not isinstance(rec.get(key), kind):
            return f"{key!r} is not a {kind.__name__}" if key in rec else f"no {key!r}"
    if rec["id"] != cell_id(rec["params"]):
        return f"its id {rec['id']!r} is not the digest of its params"
    if not rec["methods"]:
        return "no method results"
    for name, m in rec["methods"].items():
        if not isinstance(m, dict) or not isinstance(m.get("runs"), list):
            return f"method {name!r} without its runs"
        for r in m["runs"]:
            if not isinstance(r, dict) or not isinstance(r.get("status"), str):
                return f"a run of {name!r} without its status"
            bad = [k for k in _NUMBERS if not _number(r.get(k))]
            if bad:
                return f"a run of {name!r}: {bad[0]} is {r[bad[0]]!r}, not a number"
        if not _number(m.get("observed_order")):
            return f"method {name!r}: observed_order is {m['observed_order']!r}, not a number"
    if not all(k in rec["timings"] and _number(rec["timings"][k]) for k in ("context", "reference", "compute")):
        return "timings without numbers for context, reference and compute"
    return None


# ------------------------------------------------------------------------------------------------------
# planning: chunks of cells that can share a batch
# ------------------------------------------------------------------------------------------------------
def _batch_key(sc) -> str:
    """Cells with the same key differ only in initial state or inertia: one integrate_batch call serves them. A
    gyrostat's wheels' momentum is part of its torque, and it follows the body rate and the wheels' speeds: its
    cells share a batch only where both are the same."""
    return json.dumps([str(sc.model), sc.torque, sc.duration, sc.sequence, sc.reference, sc.reference_method,
                       sc.reference_dt, *((list(sc.omega0), sc.wheel_speeds) if _has_wheels(*_stamp(sc.model)) else ())],
                      sort_keys=True, default=str)


def _stamp(model) -> tuple[str, int]:
    return str(model), os.stat(model).st_mtime_ns


@functools.lru_cache(maxsize=64)
def _has_wheels(model: str, mtime_ns: int) -> bool:
    """Whether a model (as it is at ``mtime_ns``) is a gyrostat: loaded once per model while a sweep is planned,
    not once per cell."""
    from ..models import load_body

    return bool(load_body(model).wheels)


def plan_chunks(spec: SweepSpec, cells: list[dict]) -> list[list[tuple]]:
    """``cells`` (``{"id", "params"}``) as chunks of ``(id, params, scenario)``: grouped by batch key (in the
    order of first appearance), then cut into chunks of at most :data:`CHUNK` cells. Independent of the
    executor and the number of workers, so that every executor computes the same batches."""
    groups: dict[str, list] = {}
    for cell in cells:
        sc = apply_cell(spec.base, cell["params"])
        sc.name = spec.base.name
        groups.setdefault(_batch_key(sc), []).append((cell["id"], cell["params"], sc))
    size = max(1, min(CHUNK, math.ceil(len(cells) / MIN_TASKS)))
    return [g[i:i + size] for g in groups.values() for i in range(0, len(g), size)]


# ------------------------------------------------------------------------------------------------------
# in a worker
# ------------------------------------------------------------------------------------------------------
@dataclass
class _Cell:
    id: str
    params: dict
    scenario: object
    ctx: object = None
    ref: object = None
    failure: str | None = None  # the reference could not be built
    timings: dict = field(default_factory=lambda: {"context": 0.0, "reference": 0.0, "compute": 0.0})
    results: list = field(default_factory=list)


def run_chunk(chunk: list[tuple], methods: list[str], steps: tuple) -> list[dict]:
    """Every method of every cell of ``chunk`` at every step (in a worker): one record per cell (see
    :func:`_record`). Our methods with a batch path run every cell of the chunk in one
    :func:`~xcheck.integrators.integrate_batch` call per step; the others run cell by cell."""
    import warnings

    from ..reference import ReferenceFailure
    from ..study.context import run_context, scenario_reference
    from ..trajectory import step_plan, time_grid

    warnings.filterwarnings("ignore", category=UserWarning, module="xcheck.models")
    cells = [_Cell(cid, params, sc) for cid, params, sc in chunk]
    grids = [time_grid(step_plan(dt, cells[0].scenario.duration)[0], dt, cells[0].scenario.duration) for dt in steps]
    for c in cells:
        t0 = time.perf_counter()
        c.ctx = run_context(c.scenario)
        t1 = time.perf_counter()
        try:
            c.ref = scenario_reference(c.scenario)
            for t in grids:  # evaluated once per grid now, so that the runs' times are the runs' own
                c.ref.at(t)
        except ReferenceFailure as exc:
            c.failure = str(exc)
        c.timings["context"], c.timings["reference"] = t1 - t0, time.perf_counter() - t1
    live = [c for c in cells if c.failure is None]
    for method in methods:
        runner = RUNNERS[method]
        if runner.run_batch is not None and len(live) > 1:
            _run_batched(method, live, steps)
        else:
            for c in live:
                _run_single(method, c, steps, methods)
    return [_record(c, methods, steps) for c in cells]


def _run_single(method: str, c: _Cell, steps: tuple, methods=()) -> None:
    """One method's runs of a cell, an engine's compared with its partner of ours at each step (what its agreement
    check reads where the steps leave both above the limit: :func:`xcheck.study.checks._agreement`)."""
    from ..study import comparison_partner
    from ..study.measure import measure_method

    t0 = time.perf_counter()
    res = measure_method(c.scenario, method, steps, comparison_partner(c.scenario, method, methods), sample=False,
                         tolerances=c.scenario.quick_tolerances)
    c.timings["compute"] += time.perf_counter() - t0
    c.results.append(res)


_WARM_BATCH: set = set()


def _run_batched(method: str, cells: list[_Cell], steps: tuple) -> None:
    """One integrate_batch call per step for all ``cells`` (same model, torque, duration); each run's wall
    time is the call's divided by the number of cells."""
    from ..integrators import METHODS, integrate_batch
    from ..results import MethodRuns, Run
    from ..study.measure import measure_run
    from ..trajectory import Trajectory

    ctx0 = cells[0].ctx
    stages = METHODS[method].stages
    inertia = np.stack([c.ctx.inertia for c in cells])
    q0 = np.stack([c.ctx.q0 for c in cells])
    omega0 = np.stack([c.ctx.omega0 for c in cells])
    kwargs = dict(torque=ctx0.torque, sequence=ctx0.sequence, save="all")
    if method not in _WARM_BATCH:  # load (or compile) the batch kernel before it is timed
        _WARM_BATCH.add(method)
        h = min(steps)
        integrate_batch(method, inertia[:1], q0[:1], omega0[:1], dt=h, duration=min(ctx0.duration, 2 * h), **kwargs)
    runs: list[list] = [[] for _ in cells]
    for dt in steps:
        t0 = time.perf_counter()
        try:
            out = integrate_batch(method, inertia, q0, omega0, dt=dt, duration=ctx0.duration, **kwargs)
        except ValueError as exc:
            wall = (time.perf_counter() - t0) / len(cells)
            for r in runs:
                r.append(Run.failed(dt, "failed", f"{method}: {exc}", wall))
            continue
        wall = (time.perf_counter() - t0) / len(cells)
        for i, c in enumerate(cells):
            k = int(out.steps_done[i]) + 1
            traj = Trajectory(t=out.t[:k], q=out.q[i, :k], omega=out.omega[i, :k], method=method, dt=dt,
                              extras={"evaluations": stages * int(out.steps_done[i])})
            if out.status[i] != "ok":
                traj.status = str(out.status[i])
                traj.message = (f"{method}: the run stopped ({out.status[i]}) at t = {out.t[k - 1]:.6g} s; the "
                                "trajectory ends at the last good step")
            t1 = time.perf_counter()
            runs[i].append(measure_run(method, traj, c.ref, c.ctx, dt, wall))
            c.timings["compute"] += wall + (time.perf_counter() - t1)
    for c, r in zip(cells, runs):
        c.results.append(MethodRuns(method, r, batched=True, reference_check=c.ref.check))


def _record(c: _Cell, methods: list[str], steps: tuple) -> dict:
    """A cell's record: its parameters, every method's result (schema ``xcheck.convergence/3``'s method
    entries), the checks, whether it passed, and where its time went."""
    from ..results import MethodRuns
    from ..study import assemble
    from ..study.measure import settings

    if c.failure is not None:
        c.results = [MethodRuns.without_reference(m, settings(c.scenario, RUNNERS[m], steps,
                                                              c.scenario.quick_tolerances), c.failure)
                     for m in methods]
    st = assemble(c.scenario, list(steps), c.results, quick=True)
    return {"id": c.id, "params": c.params, "passed": st.passed, "outcome": st.outcome, "order_floor": st.order_floor,
            "methods": {n: m.to_json() for n, m in st.methods.items()},
            "batched": sorted(r.method for r in c.results if r.batched),
            "checks": [ch.to_json() for ch in st.checks],
            "timings": {k: round(v, 6) for k, v in c.timings.items()}}


# ------------------------------------------------------------------------------------------------------
# the sweep
# ------------------------------------------------------------------------------------------------------
#: What a sweep's workers import as they start.
WORKER_MODULES = ("xcheck.sweep.run", "xcheck.study", "xcheck.engines.mujoco")


@dataclass
class Cells:
    """What :func:`run_cells` did: every cell's record (spec order), how many cells ran now and how many came from
    an earlier run (``--resume``), the timings (``timings``: executor start [s], per-cell medians [s] of context
    (model load, torque), reference and compute, and cells per second), the methods and the log (removed by the
    caller once the sweep's folder is written: :func:`xcheck.commands.sweeps.run_sweep`)."""

    records: list
    ran: int
    reused: int
    timings: dict
    methods: tuple
    log: Path


#: The log of an unfinished sweep, in the sweep's folder (``<out>/<spec stem>/``).
PARTIAL_LOG = ".cells-partial.jsonl"


def run_cells(spec: SweepSpec, root: Path, *, jobs: int = 1, resume: bool = False, kind: str = "local",
              scheduler: str | None = None, progress=None, say=print) -> Cells:
    """Run every cell of ``spec`` not yet finished, each logged in ``root/`` (:data:`PARTIAL_LOG`) as its chunk
    ends. ``resume``: keep the cells of an interrupted run (its log), or of the latest complete one
    (``latest/cells.jsonl``: a spec given more values runs only the new cells). ``progress(done, total, label)`` as
    chunks finish; ``say(text)`` for notes. The caller holds ``root`` (one run at a time)."""
    t_start = time.perf_counter()
    log = SweepLog(root / PARTIAL_LOG, fingerprint(spec))
    if resume:
        source = next((p for p in (log.path, root / "latest" / "cells.jsonl") if p.is_file()), None)
        if source is None:
            say(f"--resume: no earlier run of this sweep in {root}; running every cell")
        else:
            log.read(source)
    wanted = {c["id"] for c in spec.cells}
    log.records = {k: v for k, v in log.records.items() if k in wanted}
    reused = len(log.records)
    todo = [c for c in spec.cells if c["id"] not in log.records]
    if resume and log.records:
        say(f"--resume: {reused} of {len(spec.cells)} cells already done; running {len(todo)}")
    chunks = plan_chunks(spec, todo)
    methods = sweep_methods(spec)
    t_ready = t_end = time.perf_counter()
    # an earlier run's log is cut (or its cells dropped) only once this run is known to start: its executor is up
    with (executor(kind, min(jobs, max(1, len(chunks))), scheduler, warm=WORKER_MODULES) if chunks
          else nullcontext()) as ex:
        t_ready = time.perf_counter()
        if not resume and log.path.exists():
            say(f"note: an interrupted run left {log.path}; starting over (--resume keeps its finished cells)")
        log.start()
        if chunks:
            futures = [ex.submit(run_chunk, ch, methods, tuple(spec.steps)) for ch in chunks]
            done = 0
            for fut in ex.as_completed(futures):
                records = fut.result()
                log.append(records)
                done += len(records)
                if progress:
                    progress(done, len(todo), f"{done} of {len(todo)} cells")
            t_end = time.perf_counter()
    fresh = [log.records[c["id"]] for c in todo]
    timings = {"executor_start": t_ready - t_start, "cells_per_second": len(todo) / (t_end - t_ready) if todo else None,
               **{k: float(np.median([r["timings"][k] for r in fresh])) if fresh else None
                  for k in ("context", "reference", "compute")}}
    return Cells(records=[log.records[c["id"]] for c in spec.cells], ran=len(todo), reused=reused, timings=timings,
                 methods=methods, log=log.path)
