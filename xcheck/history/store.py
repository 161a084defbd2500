"""The nightly history: every figure of every report, in one database, and what changed between runs (issue 11).

A history is a SQLite file (Python's own ``sqlite3``; ``reports/history.sqlite`` by default) or, for a team,
a PostgreSQL database (``postgresql://...``, through the optional ``psycopg`` driver: ``pip install
xcheck[postgres]``), with three tables:

``xcheck_meta``  (key, value): ``application = xcheck.history`` and ``schema_version``; a database without it
                 is not an xcheck history and is refused untouched, as is one written by a newer schema.
``runs``         one row per recorded report: id, start and end time (UTC, ISO 8601), git commit of the
                 project (when it ran from a checkout), versions of xcheck, mujoco, numpy, scipy, numba and
                 python, host, CPU count, whether it passed, the report folder, whether it was a quick report,
                 and its environment (``""``: the one xcheck runs in; ``mujoco==3.6.0``: a run of the MuJoCo
                 version matrix in its own virtual environment).
``metrics``      one row per figure: run id, scenario, method, step ``dt`` [s] (NULL for a figure of the whole
                 method or scenario), metric name, value. Names: ``attitude_error`` ``max_attitude_error``
                 ``energy_change`` ``momentum_change`` (signed: + gained, - damped) ``momentum_turn`` [rad]
                 ``norm_drift`` ``wall_time`` ``steps_per_second`` per run (before xcheck.convergence/3, unsigned
                 ``energy_drift`` and ``momentum_drift``, |L - L0| / |L0|: old rows keep those names);
                 ``observed_order`` ``finest_error`` ``verdict`` (1 pass, 0 fail) per method; ``passed`` and
                 ``order_floor`` per scenario (method ``""``); ``check:<name>`` (1 passed, 0.5 inconclusive, 0 failed)
                 per check (``passed`` per scenario likewise, by its outcome);
                 ``bench_steps_per_second`` per ``xcheck bench`` row (scenario, method, dt NULL, the batch size
                 in the method name when > 1). An adaptive method's runs share one output step: each is recorded
                 under the method's name and its tolerance (``basilisk-rkf45 rtol=1e-06``), at that step.
``sweep_cells``  (schema 2) the parameters of a sweep's cells (``xcheck sweep``): run id, scenario (the cell's
                 name in ``metrics``: ``<base>/<cell id>``), parameter (an axis, one component of a vector axis, or
                 its summary: ``dipole_scale``, ``rate_x``, ``attitude_angle_deg``), value (a number) or text (a
                 model file, a field model). Join it with ``metrics`` on run id and scenario.

A run is recorded in one transaction after its report is complete: a run that fails or is interrupted
records nothing, and a killed writer leaves the database as it was. Concurrent writers wait for each other
(SQLite: a busy timeout; PostgreSQL: its own locking).
"""

from __future__ import annotations

import math
import sqlite3
import statistics
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from ..base.errors import UserError
from ..results import outcome_value

APPLICATION = "xcheck.history"
#: Raise with every change of the tables, and migrate older databases in ``History.__init__``.
SCHEMA_VERSION = 2
#: Seconds a writer waits for another's transaction before giving up.
BUSY_TIMEOUT = 60.0

RUN_COLUMNS = ("started", "finished", "git_commit", "xcheck", "mujoco", "numpy", "scipy", "numba", "python",
               "host", "cpus", "passed", "report", "quick", "environment")
RUN_METRICS = ("attitude_error", "max_attitude_error", "energy_change", "momentum_change", "momentum_turn",
               "norm_drift", "wall_time", "steps_per_second")
#: Versions whose change between two runs is marked on the History section's time axis.
VERSION_COLUMNS = ("xcheck", "mujoco", "numpy", "scipy", "numba", "python")
TABLES = ("xcheck_meta", "runs", "metrics", "sweep_cells")

# {id} and {real} are the dialect's: SQLite's REAL is a double, PostgreSQL's a single (DOUBLE PRECISION there)
_SCHEMA = """
CREATE TABLE IF NOT EXISTS xcheck_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    id {id},
    started TEXT NOT NULL, finished TEXT NOT NULL, git_commit TEXT,
    xcheck TEXT, mujoco TEXT, numpy TEXT, scipy TEXT, numba TEXT, python TEXT,
    host TEXT, cpus INTEGER, passed INTEGER NOT NULL, report TEXT,
    quick INTEGER NOT NULL DEFAULT 0, environment TEXT NOT NULL DEFAULT '');
CREATE TABLE IF NOT EXISTS metrics (
    run_id INTEGER NOT NULL REFERENCES runs(id),
    scenario TEXT NOT NULL, method TEXT NOT NULL, dt {real}, metric TEXT NOT NULL, value {real});
CREATE INDEX IF NOT EXISTS metrics_by_run ON metrics (run_id);
CREATE INDEX IF NOT EXISTS metrics_by_key ON metrics (scenario, method, metric, dt);
CREATE TABLE IF NOT EXISTS sweep_cells (
    run_id INTEGER NOT NULL REFERENCES runs(id),
    scenario TEXT NOT NULL, parameter TEXT NOT NULL, value {real}, text TEXT);
CREATE INDEX IF NOT EXISTS sweep_cells_by_run ON sweep_cells (run_id, scenario)
"""


class HistoryError(UserError):
    """A history that cannot be used (not a database, not xcheck's, a newer schema, cannot be opened): the
    message names the file or URL and what was expected; the database is left untouched."""


def is_url(location) -> bool:
    return str(location).startswith(("postgresql://", "postgres://"))


def _password(url: str) -> str | None:
    """The password a PostgreSQL URL carries (``user:password@`` or ``?password=``), if any."""
    from urllib.parse import parse_qs, unquote, urlsplit

    parts = urlsplit(url)
    if parts.password:
        return unquote(parts.password)
    given = parse_qs(parts.query).get("password")
    return given[0] if given else None


def display(location) -> str:
    """A history's location for messages: a URL without its password (in the credentials or the query)."""
    text = str(location)
    if not is_url(text):
        return text
    scheme, rest = text.split("://", 1)
    rest, _, query = rest.partition("?")
    if "@" in rest:
        cred, host = rest.rsplit("@", 1)
        rest = f"{cred.split(':', 1)[0]}@{host}"
    kept = "&".join(p if not p.lower().startswith("password=") else "password=***" for p in query.split("&"))
    return f"{scheme}://{rest}" + (f"?{kept}" if query else "")


def scrub(text: str, location) -> str:
    """``text`` (a driver's message) with the password of the URL ``location`` masked wherever it appears."""
    secret = _password(str(location)) if is_url(location) else None
    return text.replace(secret, "***") if secret else text


# -----------------------------------------------------------------------------------------------------
# the two databases: what differs between them, and nothing else (SQL is written with SQLite's ``?``)
# -----------------------------------------------------------------------------------------------------
class _SQLite:
    id_column, real = "INTEGER PRIMARY KEY AUTOINCREMENT", "REAL"
    errors = (sqlite3.Error,)

    def __init__(self, path: Path):
        self.where = str(path)
        if path.is_dir():
            raise HistoryError(f"{path}: is a folder; expected an xcheck history file (SQLite)")
        if not path.parent.is_dir():
            raise HistoryError(f"{path}: its folder {path.parent} does not exist")
        self.path = path

    def connect(self, read_only: bool):
        if read_only:  # nothing is created or written by a check
            return sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True, timeout=BUSY_TIMEOUT)
        return sqlite3.connect(self.path, timeout=BUSY_TIMEOUT, isolation_level=None)

    def exists(self) -> bool:
        return self.path.exists()

    def interrupted_write(self) -> bool:
        """Whether a writer's journal is left beside the file (SQLite's rollback journal, not yet rolled back)."""
        journal = self.path.with_name(self.path.name + "-journal")
        return journal.is_file() and journal.stat().st_size > 0

    def tables(self, con) -> set[str]:
        return {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}

    def begin(self, con) -> None:
        con.execute("BEGIN IMMEDIATE")  # the write lock now: two writers queue instead of deadlocking

    def check_writable(self, con) -> None:
        """Tried, not inferred from permission bits (root ignores them; a read-only mount does not): the file
        opens for writing, and its folder takes a new file (SQLite's journal, written beside it)."""
        try:
            if self.path.exists():
                with open(self.path, "r+b"):
                    pass
            with tempfile.NamedTemporaryFile(dir=self.path.parent, prefix=f".{self.path.name}-write-check-"):
                pass
        except OSError as exc:
            what = "it" if exc.filename == str(self.path) else f"its folder {self.path.parent}"
            raise HistoryError(f"{self.where}: {what} cannot be written ({exc.strerror or exc}); SQLite writes the "
                               "file and a journal beside it: give a writable --history") from None

    def check_intact(self, con) -> None:
        rows = [r[0] for r in con.execute("PRAGMA quick_check").fetchall()]
        if rows != ["ok"]:
            raise HistoryError(f"{self.where}: damaged (SQLite's integrity check: {'; '.join(rows[:3])}); restore "
                               "it from a copy or give another --history")

    @staticmethod
    def sql(statement: str) -> str:
        return statement

    @staticmethod
    def executemany(con, statement, rows) -> None:
        con.executemany(statement, rows)


class _Postgres:
    id_column, real = "BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY", "DOUBLE PRECISION"

    def __init__(self, url: str):
        self.where = display(url)
        try:
            import psycopg
        except ImportError:
            raise HistoryError(f"{self.where}: a PostgreSQL history needs the psycopg driver: "
                               "pip install 'xcheck[postgres]'") from None
        self.psycopg, self.url = psycopg, url
        self.errors = (psycopg.Error,)

    def connect(self, read_only: bool):
        try:
            return self.psycopg.connect(self.url, autocommit=True, connect_timeout=int(BUSY_TIMEOUT))
        except self.psycopg.Error as exc:
            raise HistoryError(f"{self.where}: cannot be opened ({scrub(str(exc).strip().splitlines()[0], self.url)})"
                               ) from None

    def exists(self) -> bool:
        return True

    def interrupted_write(self) -> bool:  # the server rolls back a writer's transaction itself
        return False

    def tables(self, con) -> set[str]:
        return {r[0] for r in con.execute("SELECT table_name FROM information_schema.tables "
                                          "WHERE table_schema = current_schema()")}

    def begin(self, con) -> None:
        con.execute("BEGIN")
        con.execute("SELECT pg_advisory_xact_lock(7207315)")  # one writer at a time, as with SQLite

    def check_writable(self, con) -> None:
        tables = self.tables(con) & {"runs", "metrics", "sweep_cells"}
        if tables:
            refused = [t for t in sorted(tables)
                       if not con.execute("SELECT has_table_privilege(%s, 'INSERT')", (t,)).fetchone()[0]]
        else:
            refused = [] if con.execute("SELECT has_schema_privilege(current_schema(), 'CREATE')").fetchone()[0] \
                else ["the schema (CREATE)"]
        if refused:
            raise HistoryError(f"{self.where}: cannot be written (this user may not insert into "
                               f"{', '.join(refused)}): give a writable --history")

    def check_intact(self, con) -> None:  # the server keeps its pages; a damaged one reports as it reads
        pass

    @staticmethod
    def sql(statement: str) -> str:
        return statement.replace("?", "%s")

    @staticmethod
    def executemany(con, statement, rows) -> None:
        with con.cursor() as cur:
            cur.executemany(statement, rows)


def _refuse_foreign(db, con) -> bool:
    """Refuse a database that is not an xcheck history of this or an older schema (read only); returns whether
    it is one (False: an empty database, which becomes one when written)."""
    tables = db.tables(con)
    if "xcheck_meta" not in tables:
        ours = tables & set(TABLES)
        if ours or (tables and not is_url(db.where)):
            raise HistoryError(f"{db.where}: a database but not an xcheck history (no xcheck_meta table; it has "
                               f"{', '.join(sorted(tables))}); give another --history")
        return False
    meta = dict(con.execute("SELECT key, value FROM xcheck_meta").fetchall())
    if meta.get("application") != APPLICATION:
        raise HistoryError(f"{db.where}: not an xcheck history (application {meta.get('application')!r})")
    try:
        version = int(meta.get("schema_version", "0"))
    except ValueError:
        raise HistoryError(f"{db.where}: damaged: its schema_version {meta.get('schema_version')!r} is not a "
                           "number") from None
    missing = [t for t in ("runs", "metrics") if t not in tables]
    if missing:
        raise HistoryError(f"{db.where}: damaged: an xcheck history without its {' and '.join(missing)} "
                           f"table{'s' * (len(missing) > 1)}")
    if version > SCHEMA_VERSION:
        raise HistoryError(f"{db.where}: written by a newer xcheck (history schema {version}; this release reads up "
                           f"to {SCHEMA_VERSION}); upgrade xcheck or give another --history")
    return True


class History:
    """An open history (see the module docstring); use :func:`open_history`."""

    def __init__(self, location, *, read_only: bool = False):
        self.db = _Postgres(str(location)) if is_url(location) else _SQLite(Path(location))
        self.where = self.db.where
        self.read_only = read_only
        self.empty = True  # no tables yet (a new file, or an empty database)
        if self.db.exists():
            con = None
            try:
                # read only: a check writes nothing. A writer's check reads through a connection that may write, so
                # that a journal left by a writer killed mid-transaction (a hot journal) is rolled back, as SQLite
                # does on the first read: the file as it was before that transaction, where a read-only connection
                # cannot read it at all ("attempt to write a readonly database"). The file exists: nothing is created
                con = self.db.connect(read_only=read_only)
                self.empty = not _refuse_foreign(self.db, con)
            except self.db.errors as exc:
                if read_only and self.db.interrupted_write():
                    raise HistoryError(f"{self.where}: a write to it was interrupted and its journal is left beside "
                                       "it; a nightly (any command that writes the history) rolls it back") from None
                raise HistoryError(f"{self.where}: not an xcheck history, or it cannot be read: {exc}") from None
            finally:
                if con is not None:
                    con.close()
        elif read_only:
            raise HistoryError(f"{self.where}: no such history")
        try:
            self.con = self.db.connect(read_only=read_only)
        except self.db.errors as exc:
            raise HistoryError(f"{self.where}: cannot be opened ({exc})") from None
        if read_only:
            return
        self.empty = False
        with self.transaction():  # a fresh database becomes a history, atomically
            for statement in _SCHEMA.format(id=self.db.id_column, real=self.db.real).split(";"):
                self.con.execute(statement)
            for key, value in (("application", APPLICATION), ("schema_version", str(SCHEMA_VERSION))):
                self._execute("INSERT INTO xcheck_meta VALUES (?, ?) ON CONFLICT (key) DO NOTHING", (key, value))
            # schema 1 -> 2: the sweep_cells table, created above
            self._execute("UPDATE xcheck_meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION),))

    def check(self) -> None:
        """Before any work that will be recorded: every page can be read and the history can be written
        (:class:`HistoryError` otherwise; nothing is written)."""
        try:
            self.db.check_intact(self.con)
            if not self.empty:
                for table in ("runs", "metrics"):  # every row decoded (a value SQLite cannot read, too), none kept
                    for _ in self._execute(f"SELECT * FROM {table}"):
                        pass
        except self.db.errors as exc:
            raise HistoryError(f"{self.where}: damaged, it cannot be read ({exc}); restore it from a copy or give "
                               "another --history") from None
        self.db.check_writable(self.con)

    def _execute(self, statement, params=()):
        return self.con.execute(self.db.sql(statement), params)

    def close(self) -> None:
        self.con.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @contextmanager
    def transaction(self):
        """BEGIN (SQLite: IMMEDIATE, the write lock at once) ... COMMIT; ROLLBACK on any exception, Ctrl-C
        included."""
        self.db.begin(self.con)
        try:
            yield
        except BaseException:
            self.con.execute("ROLLBACK")
            raise
        self.con.execute("COMMIT")

    # -------------------------------------------------------------------------------------------------
    def record(self, results: dict, *, started: str, finished: str, git_commit: str | None = None,
               host: str | None = None, report: str | None = None, throughput=None, environment: str = "") -> int:
        """Store a report's ``results.json`` document (and ``xcheck bench`` rows) as one run; returns its id.
        (:meth:`record_runs` also takes ``cells``: ``(scenario, parameter, value)`` rows of a sweep.)"""
        return self.record_runs([dict(results=results, started=started, finished=finished, git_commit=git_commit,
                                      host=host, report=report, throughput=throughput, environment=environment)])[0]

    def record_runs(self, runs: list[dict]) -> list[int]:
        """Several runs (each the keyword arguments of :meth:`record`) in one transaction: all or none."""
        ids = []
        try:
            self._insert_runs(runs, ids)
        except self.db.errors as exc:  # locked beyond the busy timeout, disk full, a server gone
            raise HistoryError(f"{self.where}: could not record the run ({exc}); nothing was recorded") from None
        return ids

    def _insert_runs(self, runs, ids) -> None:
        with self.transaction():
            for run in runs:
                run = dict(run)
                results, throughput, cells = run.pop("results"), run.pop("throughput", None), run.pop("cells", ())
                row = run_row(results, **run)
                run_id = self._execute(f"INSERT INTO runs ({', '.join(RUN_COLUMNS)}) VALUES "
                                       f"({', '.join('?' * len(RUN_COLUMNS))}) RETURNING id",
                                       [row[c] for c in RUN_COLUMNS]).fetchone()[0]
                metrics = [*report_metrics(results), *bench_metrics(throughput)]
                self.db.executemany(self.con, self.db.sql("INSERT INTO metrics VALUES (?, ?, ?, ?, ?, ?)"),
                                    [(run_id, *m[:4], _finite(m[4])) for m in metrics])
                if cells:
                    self.db.executemany(self.con, self.db.sql("INSERT INTO sweep_cells VALUES (?, ?, ?, ?, ?)"),
                                        [(run_id, sc, name, _finite(v) if isinstance(v, (int, float)) else None,
                                          v if isinstance(v, str) else None) for sc, name, v in cells])
                ids.append(run_id)

    def runs(self, *, quick: bool | None = None, environment: str | None = None) -> list[dict]:
        """Every run, oldest first (only quick or full ones, only one environment, when asked)."""
        if self.empty:
            return []
        cur = self._execute(f"SELECT id, {', '.join(RUN_COLUMNS)} FROM runs ORDER BY id")
        names = [d[0] for d in cur.description]
        rows = [dict(zip(names, r)) for r in cur.fetchall()]
        return [r for r in rows if (quick is None or bool(r["quick"]) == quick)
                and (environment is None or r["environment"] == environment)]

    def metrics(self, run_id: int) -> dict[tuple, float]:
        """``{(scenario, method, dt, metric): value}`` of one run."""
        return {(s, m, dt, k): v for s, m, dt, k, v in self._execute(
            "SELECT scenario, method, dt, metric, value FROM metrics WHERE run_id = ?", (run_id,)).fetchall()}


def utc_now() -> str:
    """The time now in UTC, ISO 8601 to the second: a run's ``started`` and ``finished``."""
    from datetime import datetime, timezone

    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _finite(value):
    return None if value is None or not math.isfinite(value) else float(value)


def run_row(results: dict, *, started: str, finished: str, git_commit=None, host=None, report=None,
            environment: str = "") -> dict:
    """A report's row of the ``runs`` table (without its id)."""
    versions = results.get("versions", {})
    return {"started": started, "finished": finished, "git_commit": git_commit,
            **{k: versions.get(k) for k in VERSION_COLUMNS},
            "host": host, "cpus": results.get("machine", {}).get("cpus"), "passed": int(bool(results["passed"])),
            "report": report, "quick": int(bool(results.get("quick"))), "environment": environment}


def check_new(location) -> None:
    """A SQLite history that does not exist yet: its folder exists and takes the new file and SQLite's journal
    (:class:`HistoryError` otherwise; nothing is left behind)."""
    _SQLite(Path(location)).check_writable(None)


def open_history(location, *, read_only: bool = False) -> History:
    """The history at ``location``, a SQLite file (created when missing) or a ``postgresql://`` URL;
    :class:`HistoryError` when it cannot be used. ``read_only``: an existing history, for reading."""
    return History(location, read_only=read_only)


def report_metrics(results: dict):
    """The ``(scenario, method, dt, metric, value)`` rows of a report's ``results.json`` document."""
    for sc in results["scenarios"]:
        name = sc["scenario"]
        yield name, "", None, "passed", outcome_value(sc.get("outcome") or ("PASSED" if sc["passed"] else "FAILED"))
        yield name, "", None, "order_floor", sc.get("order_floor")
        for check in sc.get("checks", []):
            status = check.get("status") or ("pass" if check["passed"] else "fail")
            yield name, "", None, f"check:{check['name']}", {"pass": 1.0, "known": 1.0, "inconclusive": 0.5, "fail": 0.0}[status]
        for file, f in sc.get("files", {}).items():  # a trajectory file of another simulator (issue 39)
            for metric in ("max_attitude_error", "max_rate_error", "growth"):
                if f.get(metric) is not None:
                    yield name, f"file:{file}", None, f"file_{metric}", f[metric]
        for method, m in sc["methods"].items():
            yield name, method, None, "observed_order", m.get("observed_order")
            yield name, method, None, "verdict", (0.5 if m.get("verdict") == "inconclusive"
                                                  else float(m.get("verdict") in ("pass", "expected")))
            finest = finest_error(m)
            if finest is not None:
                yield name, method, None, "finest_error", finest
            for r in m["runs"]:
                run_method = method if r.get("rtol") is None else f"{method} rtol={r['rtol']:.0e}"
                for metric in RUN_METRICS:
                    if r.get(metric) is not None:
                        yield name, run_method, r["dt"], metric, r[metric]


def finest_error(method_doc: dict) -> float | None:
    """A method's attitude error at its finest good run (an adaptive method's: at its tightest tolerance) of a
    ``results.json`` method entry, or None."""
    ok = [r for r in method_doc["runs"] if r.get("status") == "ok" and r.get("attitude_error") is not None]
    return min(ok, key=lambda r: r["dt"] if r.get("rtol") is None else r["rtol"])["attitude_error"] if ok else None


def bench_metrics(throughput):
    """The ``(scenario, method, None, "bench_steps_per_second", value)`` rows of ``xcheck bench`` rows (the batch
    size in the method's name when > 1)."""
    for r in throughput or ():
        yield (r["scenario"], r["method"] + (f" x{r['batch']}" if r.get("batch", 1) > 1 else ""), None,
               "bench_steps_per_second", r["steps_per_second"])


def as_dict(rows) -> dict[tuple, float]:
    """``{(scenario, method, dt, metric): value}`` of metric rows."""
    return {row[:4]: row[4] for row in rows}


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


def baseline_metrics(history: History, runs: list[dict], *, host: str | None = None) -> dict[tuple, float]:
    """Per figure, the median over ``runs`` (rows of :meth:`History.runs`: the rolling baseline is the last N
    runs of a series, ``--baseline RUN_ID`` one run). Speeds count only runs on ``host``."""
    values: dict[tuple, list] = {}
    for r in runs:
        for key, v in history.metrics(r["id"]).items():
            if v is None or (_is_speed(key) and r["host"] != host):
                continue
            values.setdefault(key, []).append(v)
    return {k: statistics.median(v) for k, v in values.items()}


#: A report's run shorter than this [s] times the clock and the caches more than the integrator: its speed is
#: not compared (the benchmark's rows always are: they are built for timing).
MIN_TIMED = 0.05


def _timed(metrics: dict, key) -> bool:
    wall = metrics.get((*key[:3], "wall_time"))
    return wall is not None and wall >= MIN_TIMED


def _is_speed(key) -> bool:
    return key[3] in ("steps_per_second", "wall_time", "bench_steps_per_second")


def compare(before: dict[tuple, float], after: dict[tuple, float], th: Thresholds = Thresholds()) -> list[Change]:
    """Regressions and improvements from ``before`` to ``after`` (``{(scenario, method, dt, metric): value}``).

    A regression: a check that passed and now fails; an attitude error (per run) that grew by more than
    ``error_factor`` above the study's round-off floor (``order_floor``); an observed order that dropped by more
    than ``order_drop``; a speed that dropped by more than ``speed_drop`` (speeds are compared at the finest
    step of each method, its longest run, when it lasted at least :data:`MIN_TIMED` in both; and for ``xcheck
    bench`` rows). The same rules the other way round
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
        elif metric == "bench_steps_per_second" or (metric == "steps_per_second" and dt == finest.get((s, m))
                                                    and _timed(before, key) and _timed(after, key)):
            moved("speed", a < (1 - th.speed_drop) * b, b < (1 - th.speed_drop) * a)
    return changes
