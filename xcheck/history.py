"""The nightly history: every figure of every report, in one database, and what changed between runs (issue 11).

A history is a SQLite file (Python's own ``sqlite3``; ``reports/history.sqlite`` by default) with three tables:

``xcheck_meta``  (key, value): ``application = xcheck.history`` and ``schema_version``; a file without it is
                 not an xcheck history and is refused untouched, as is one written by a newer schema.
``runs``         one row per recorded report: id, start and end time (UTC, ISO 8601), git commit of the
                 project (when it ran from a checkout), versions of xcheck, mujoco, numpy, scipy, numba and
                 python, host, CPU count, whether it passed, the report folder.
``metrics``      one row per figure: run id, scenario, method, step ``dt`` [s] (NULL for a figure of the whole
                 method or scenario), metric name, value. Names: ``attitude_error`` ``max_attitude_error``
                 ``energy_drift`` ``momentum_drift`` ``norm_drift`` ``wall_time`` ``steps_per_second`` per run;
                 ``observed_order`` ``finest_error`` ``verdict`` (1 pass, 0 fail) per method; ``passed`` and
                 ``order_floor`` per scenario (method ``""``); ``check:<name>`` (1 passed, 0 failed) per check;
                 ``bench_steps_per_second`` per ``xcheck bench`` row (scenario, method, dt NULL, the batch size
                 in the method name when > 1).

A run is recorded in one transaction after its report is complete: a run that fails or is interrupted
records nothing, and a killed writer leaves the file as it was (SQLite's journal). Concurrent writers wait
for each other (a busy timeout).
"""

from __future__ import annotations

import math
import sqlite3
import statistics
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

APPLICATION = "xcheck.history"
#: Raise with every change of the tables, and migrate older files in :func:`_migrate`.
SCHEMA_VERSION = 1
#: Seconds a writer waits for another's transaction before giving up.
BUSY_TIMEOUT = 60.0

RUN_COLUMNS = ("started", "finished", "git_commit", "xcheck", "mujoco", "numpy", "scipy", "numba", "python",
               "host", "cpus", "passed", "report")
RUN_METRICS = ("attitude_error", "max_attitude_error", "energy_drift", "momentum_drift", "norm_drift", "wall_time",
               "steps_per_second")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS xcheck_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    started TEXT NOT NULL, finished TEXT NOT NULL, git_commit TEXT,
    xcheck TEXT, mujoco TEXT, numpy TEXT, scipy TEXT, numba TEXT, python TEXT,
    host TEXT, cpus INTEGER, passed INTEGER NOT NULL, report TEXT);
CREATE TABLE IF NOT EXISTS metrics (
    run_id INTEGER NOT NULL REFERENCES runs(id),
    scenario TEXT NOT NULL, method TEXT NOT NULL, dt REAL, metric TEXT NOT NULL, value REAL);
CREATE INDEX IF NOT EXISTS metrics_by_run ON metrics (run_id);
CREATE INDEX IF NOT EXISTS metrics_by_key ON metrics (scenario, method, metric, dt);
"""


class HistoryError(ValueError):
    """A history that cannot be used (not a database, not xcheck's, a newer schema, cannot be opened): the
    message names the file and what was expected; the file is left untouched."""


def _check_existing(path: Path) -> None:
    """Refuse, without writing anything, a file that is not an xcheck history of this or an older schema."""
    if path.is_dir():
        raise HistoryError(f"{path}: is a folder; expected an xcheck history file (SQLite)")
    try:
        con = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=BUSY_TIMEOUT)
    except sqlite3.Error as exc:
        raise HistoryError(f"{path}: cannot be opened ({exc})") from None
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if not tables:
            return  # an empty SQLite file: becomes a history
        if "xcheck_meta" not in tables:
            raise HistoryError(f"{path}: a SQLite database but not an xcheck history (no xcheck_meta table; "
                               f"it has {', '.join(sorted(tables))}); give another --history file")
        meta = dict(con.execute("SELECT key, value FROM xcheck_meta"))
        if meta.get("application") != APPLICATION:
            raise HistoryError(f"{path}: not an xcheck history (application {meta.get('application')!r})")
        version = int(meta.get("schema_version", "0"))
        if version > SCHEMA_VERSION:
            raise HistoryError(f"{path}: written by a newer xcheck (history schema {version}; this release reads "
                               f"up to {SCHEMA_VERSION}); upgrade xcheck or give another --history file")
    except sqlite3.DatabaseError as exc:
        raise HistoryError(f"{path}: not an xcheck history: {exc}") from None
    finally:
        con.close()


class History:
    """An open history (see the module docstring); use :func:`open_history`."""

    def __init__(self, path: Path):
        self.path = Path(path)
        if self.path.exists():
            _check_existing(self.path)
        try:
            self.con = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT, isolation_level=None)
        except sqlite3.Error as exc:
            raise HistoryError(f"{self.path}: cannot be opened ({exc})") from None
        with self.transaction():
            for statement in filter(str.strip, _SCHEMA.split(";")):
                self.con.execute(statement)
            self.con.execute("INSERT OR IGNORE INTO xcheck_meta VALUES ('application', ?)", (APPLICATION,))
            self.con.execute("INSERT OR IGNORE INTO xcheck_meta VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))

    def close(self) -> None:
        self.con.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @contextmanager
    def transaction(self):
        """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on any exception, Ctrl-C included)."""
        self.con.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self.con.execute("ROLLBACK")
            raise
        self.con.execute("COMMIT")

    # -------------------------------------------------------------------------------------------------
    def record(self, results: dict, *, started: str, finished: str, git_commit: str | None = None,
               host: str | None = None, report: str | None = None, throughput=None) -> int:
        """Store a report's ``results.json`` document (and ``xcheck bench`` rows) as one run; returns its id."""
        versions = results.get("versions", {})
        row = {"started": started, "finished": finished, "git_commit": git_commit,
               **{k: versions.get(k) for k in ("xcheck", "mujoco", "numpy", "scipy", "numba", "python")},
               "host": host, "cpus": results.get("machine", {}).get("cpus"), "passed": int(bool(results["passed"])),
               "report": report}
        metrics = list(report_metrics(results))
        metrics += [(r["scenario"], r["method"] + (f" x{r['batch']}" if r.get("batch", 1) > 1 else ""), None,
                     "bench_steps_per_second", r["steps_per_second"]) for r in throughput or ()]
        with self.transaction():
            cur = self.con.execute(f"INSERT INTO runs ({', '.join(RUN_COLUMNS)}) VALUES "
                                   f"({', '.join('?' * len(RUN_COLUMNS))})", [row[c] for c in RUN_COLUMNS])
            run_id = cur.lastrowid
            self.con.executemany("INSERT INTO metrics VALUES (?, ?, ?, ?, ?, ?)",
                                 [(run_id, *m) for m in metrics])
        return run_id

    def runs(self) -> list[dict]:
        """Every run, oldest first."""
        cur = self.con.execute(f"SELECT id, {', '.join(RUN_COLUMNS)} FROM runs ORDER BY id")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r)) for r in cur]

    def metrics(self, run_id: int) -> dict[tuple, float]:
        """``{(scenario, method, dt, metric): value}`` of one run."""
        return {(s, m, dt, k): v for s, m, dt, k, v in self.con.execute(
            "SELECT scenario, method, dt, metric, value FROM metrics WHERE run_id = ?", (run_id,))}


def open_history(path) -> History:
    """The history at ``path`` (created when missing; :class:`HistoryError` when it cannot be used)."""
    path = Path(path)
    if not path.parent.exists():
        raise HistoryError(f"{path}: its folder {path.parent} does not exist")
    return History(path)


def report_metrics(results: dict):
    """The ``(scenario, method, dt, metric, value)`` rows of a report's ``results.json`` document."""
    for sc in results["scenarios"]:
        name = sc["scenario"]
        yield name, "", None, "passed", float(bool(sc["passed"]))
        yield name, "", None, "order_floor", sc.get("order_floor")
        for check in sc.get("checks", []):
            yield name, "", None, f"check:{check['name']}", float(bool(check["passed"]))
        for method, m in sc["methods"].items():
            yield name, method, None, "observed_order", m.get("observed_order")
            yield name, method, None, "verdict", float(m.get("verdict") in ("pass", "expected"))
            ok = [r for r in m["runs"] if r.get("status") == "ok" and r.get("attitude_error") is not None]
            if ok:
                yield name, method, None, "finest_error", min(ok, key=lambda r: r["dt"])["attitude_error"]
            for r in m["runs"]:
                for metric in RUN_METRICS:
                    if r.get(metric) is not None:
                        yield name, method, r["dt"], metric, r[metric]


# -----------------------------------------------------------------------------------------------------
# what changed
# -----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Change:
    """One figure that moved beyond its threshold between a baseline and a run."""

    kind: str  # "check" | "error" | "order" | "speed"
    scenario: str
    method: str
    dt: float | None
    before: float
    after: float
    regression: bool

    def line(self) -> str:
        what = {"check": "check", "error": "attitude error", "order": "observed order", "speed": "steps/s"}[self.kind]
        step = f" at dt = {self.dt:g} s" if self.dt is not None else ""
        fmt = (lambda v: "passed" if v >= 0.5 else "failed") if self.kind == "check" else (
            (lambda v: f"{v:.2f}") if self.kind == "order" else (lambda v: f"{v:.3g}"))
        word = "REGRESSION" if self.regression else "improved"
        return f"{word}: {self.scenario} / {self.method or '(scenario)'}{step}: {what} {fmt(self.before)} -> {fmt(self.after)}"


@dataclass(frozen=True)
class Thresholds:
    error_factor: float = 10.0  # an error that grew more than this, above the study's round-off floor
    order_drop: float = 0.3
    speed_drop: float = 0.30  # a fraction; speed only against runs on the same host


def baseline_metrics(history: History, before_run: int | None = None, *, last: int = 7,
                     host: str | None = None) -> dict[tuple, float]:
    """The rolling baseline: per figure, the median over the last ``last`` runs (before ``before_run``). Speeds
    count only runs on ``host``."""
    runs = [r for r in history.runs() if before_run is None or r["id"] < before_run][-last:]
    values: dict[tuple, list] = {}
    for r in runs:
        for key, v in history.metrics(r["id"]).items():
            if v is None or (_is_speed(key) and r["host"] != host):
                continue
            values.setdefault(key, []).append(v)
    return {k: statistics.median(v) for k, v in values.items()}


def _is_speed(key) -> bool:
    return key[3] in ("steps_per_second", "wall_time", "bench_steps_per_second")


def compare(before: dict[tuple, float], after: dict[tuple, float], th: Thresholds = Thresholds()) -> list[Change]:
    """Regressions and improvements from ``before`` to ``after`` (``{(scenario, method, dt, metric): value}``).

    A regression: a check that passed and now fails; an attitude error (per run) that grew by more than
    ``error_factor`` above the study's round-off floor (``order_floor``); an observed order that dropped by more
    than ``order_drop``; a speed that dropped by more than ``speed_drop`` (speeds are compared at the finest
    step of each method, the longest run, and for ``xcheck bench`` rows). The same rules the other way round
    are improvements."""
    changes = []
    floors = {k[0]: v for k, v in after.items() if k[3] == "order_floor" and v is not None}
    finest = {}
    for (s, m, dt, metric) in after:
        if metric == "steps_per_second" and dt is not None:
            finest[(s, m)] = min(dt, finest.get((s, m), math.inf))
    for key, a in sorted(after.items(), key=lambda kv: tuple("" if x is None else str(x) for x in kv[0])):
        s, m, dt, metric = key
        b = before.get(key)
        if a is None or b is None:
            continue

        def moved(kind, worse, better, at=dt):
            if worse or better:
                changes.append(Change(kind, s, m, at, b, a, worse))

        if metric.startswith("check:") or (metric == "passed" and m == ""):  # scenario level: the check's name
            if (b >= 0.5) != (a >= 0.5):
                changes.append(Change("check", s, metric.removeprefix("check:"), None, b, a, a < 0.5))
        elif metric == "attitude_error":
            floor = floors.get(s, 0.0)
            moved("error", a > th.error_factor * max(b, floor), b > th.error_factor * max(a, floor))
        elif metric == "observed_order":
            moved("order", b - a > th.order_drop, a - b > th.order_drop, at=None)
        elif (metric == "steps_per_second" and dt == finest.get((s, m))) or metric == "bench_steps_per_second":
            moved("speed", a < (1 - th.speed_drop) * b, b < (1 - th.speed_drop) * a)
    return changes
