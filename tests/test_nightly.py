"""``xcheck nightly`` (issue 11): runs recorded in a history, regressions caught and named, bad histories refused
untouched, concurrent runs, ``--keep``, the MuJoCo version matrix and a PostgreSQL history."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from permissions import as_a_user

from xcheck.history import nightly
from xcheck.history import store as H
from xcheck.scenario import SCENARIO_DIR

SCENARIO = "gyroscope-nonsingular"


def _nightly(*args, env=None, popen=False):
    """``xcheck nightly --quick`` in a process of its own. Speeds are not compared (``--speed-drop 1``): the
    tests share two cores, and runs of a few milliseconds are timed there (the speed rules are tested in
    test_history.py on stored numbers)."""
    cmd = [sys.executable, "-m", "xcheck", "nightly", "--quick", "--workers", "1", "--speed-drop", "1",
           *map(str, args)]
    kwargs = dict(stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                  preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    if popen:
        return subprocess.Popen(cmd, **kwargs)
    return subprocess.run(cmd, **kwargs)


def _nightly_refused(capsys, monkeypatch, *args):
    """``xcheck nightly`` as :func:`_nightly` runs it, in this process, for a refusal: no study or run may start
    (:func:`test_abuse._no_work`), and what the user is shown is the command's exit code and its stderr. A process of
    its own costs a second of imports a case and proves nothing more about a refusal made before any work."""
    from test_abuse import _no_work

    from xcheck.cli import main

    _no_work(monkeypatch)
    code = main(["nightly", "--quick", "--workers", "1", "--speed-drop", "1", *map(str, args)])
    return code, capsys.readouterr().err


#: The methods the nightly's runs here study: ours, MuJoCo's RK4 (the agreement check) and a first-order one. What
#: the nightly does with a run does not depend on how many methods it has, and each run is a process of its own.
METHODS = '["lie-rkmk4", "formulation-2", "mujoco-rk4", "mujoco-euler"]'


def _scenario_copy(folder: Path, extra: str = "") -> Path:
    """The bundled gyroscope scenario as a file of the user's, with ``extra`` TOML appended (and the
    :data:`METHODS`)."""
    text = (SCENARIO_DIR / f"{SCENARIO}.toml").read_text()
    text = text.replace('model = "../gyroscope.xml"', f'model = "{(SCENARIO_DIR.parent / "gyroscope.xml").as_posix()}"')
    text = text.replace("[study]", f"[study]\nmethods = {METHODS}")
    path = folder / f"{SCENARIO}.toml"
    path.write_text(text + extra)
    return path


def _files(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    """One history of three nightlies, the questions of several tests asked of it (issue 61: a run per question,
    not per test). Run 1 and run 2 (``--baseline 1``) pass; between them ``--baseline 7`` is refused. Then the stored
    lie-rkmk4 errors are patched 10^4 smaller (so that this run's are 10^4 larger than the baseline's) and the
    scenario's agreement tolerance made impossible (1e-30 rad) for run 3. Every run with ``--keep 2``. What each test
    reads is kept as it was when its run ended: ``procs``, ``results`` (run -> its results.json), ``after_run_1``
    (the history's files then)."""
    folder = tmp_path_factory.mktemp("series")
    out, scenario = folder / "reports", _scenario_copy(folder)
    procs, results = {}, {}
    procs[1] = _nightly(scenario, "--out", out, "--keep", "2")
    after_run_1 = _files_of_history(out)
    procs[2] = _nightly(scenario, "--out", out, "--keep", "2", "--baseline", "1")
    for n in (1, 2):
        assert procs[n].returncode == 0, procs[n].stdout + procs[n].stderr
    results[2] = json.loads((out / "latest" / "results.json").read_text())
    procs["baseline 7"] = _nightly(scenario, "--out", out, "--keep", "2", "--baseline", "7")
    con = sqlite3.connect(out / "history.sqlite")
    con.execute("UPDATE metrics SET value = value * 1e-4 WHERE method = 'lie-rkmk4' AND metric = 'attitude_error'")
    con.commit()
    con.close()
    _scenario_copy(folder, "\n[checks]\nagreement = 1e-30\n")
    procs[3] = _nightly(scenario, "--out", out, "--keep", "2")
    results[3] = json.loads((out / "latest" / "results.json").read_text())
    return {"out": out, "procs": procs, "results": results, "after_run_1": after_run_1}


def _files_of_history(out: Path) -> dict:
    """The history's files (SQLite's own beside it too, if any) as they are now: name -> bytes."""
    return {p.name: p.read_bytes() for p in out.glob("history.sqlite*")}


def test_two_runs_then_an_injected_regression_exits_1_and_names_it(series):
    """Runs 1 and 2 pass into a fresh history (exit 0); run 3, against errors patched 10^4 smaller and an
    impossible agreement tolerance (:func:`series`), exits 1 and names both, in its output and in its report."""
    out, procs = series["out"], series["procs"]
    for n in (1, 2):
        assert f"nightly: run {n} recorded in {out / 'history.sqlite'}" in procs[n].stdout
    assert "the first run of its series" not in procs[2].stdout
    proc = procs[3]
    assert proc.returncode == 1, proc.stdout + proc.stderr
    check = f"REGRESSION: {SCENARIO} / agreement:mujoco-rk4: check passed -> failed"
    error = re.compile(rf"REGRESSION: {SCENARIO} / lie-rkmk4 at dt = 0.015625 s: attitude error \S+ -> \S+")
    assert check in proc.stdout and error.search(proc.stdout), proc.stdout
    assert "FAILED, 2 regressions" not in proc.stdout and "FAILED" in proc.stdout.splitlines()[-1]
    report = (out / "latest" / "report.md").read_text()
    assert "## History — ❌ regression" in report
    assert f"| ❌ REGRESSION | {SCENARIO} | agreement:mujoco-rk4 |" in report
    assert f"| ❌ REGRESSION | {SCENARIO} | lie-rkmk4 | 1/64 | attitude error [rad] |" in report
    lines = [c["line"] for c in series["results"][3]["history"][0]["since_baseline"] if c["regression"]]
    assert check in lines
    with H.open_history(out / "history.sqlite", read_only=True) as hist:
        runs = hist.runs()
    assert [r["passed"] for r in runs] == [1, 1, 0] and all(r["quick"] == 1 for r in runs)
    assert runs[2]["report"] == str((out / "latest").resolve())


def _history_with_rows(path: Path, rows: int = 20000) -> None:
    """A history with one run and enough metrics to fill many pages (the nightly's would)."""
    H.open_history(path).close()
    con = sqlite3.connect(path)
    con.execute("INSERT INTO runs (started, finished, passed) VALUES ('s', 'f', 1)")
    con.executemany("INSERT INTO metrics VALUES (1, 'sc', 'm', ?, 'attitude_error', ?)",
                    [(k * 1e-3, float(k)) for k in range(rows)])
    con.commit()
    con.close()


def _overwrite_page(path: Path, which: str) -> None:
    """Bytes over one page: ``middle`` (a page of the metrics table) or ``last`` (an index's)."""
    size = sqlite3.connect(path).execute("PRAGMA page_size").fetchone()[0]
    pages = path.stat().st_size // size
    with open(path, "r+b") as f:
        f.seek((pages // 2 if which == "middle" else pages - 1) * size)
        f.write(bytes(range(256)) * (size // 256))


def _sql(statement):
    def make(path):
        _history_with_rows(path, rows=10)
        con = sqlite3.connect(path)
        con.execute(statement)
        con.commit()
        con.close()
    return make


@pytest.mark.parametrize("make, words", [
    (lambda p: p.write_bytes(b"SQLite format 3\x00" + b"\x13" * 3000), "not an xcheck history"),
    (lambda p: sqlite3.connect(p).execute("CREATE TABLE invoices (id INTEGER)").connection.commit(),
     "not an xcheck history (no xcheck_meta table; it has invoices)"),
    (lambda p: (H.open_history(p).close(), sqlite3.connect(p).execute(
        f"UPDATE xcheck_meta SET value = '{H.SCHEMA_VERSION + 1}' WHERE key = 'schema_version'").connection.commit()),
     f"written by a newer xcheck (history schema {H.SCHEMA_VERSION + 1}"),
    # issue 24, item 5: damaged histories
    (lambda p: (_history_with_rows(p), _overwrite_page(p, "middle")), "damaged"),  # a page of metrics
    (lambda p: (_history_with_rows(p), _overwrite_page(p, "last")), "damaged"),  # an index's page
    (_sql("UPDATE xcheck_meta SET value = 'abc' WHERE key = 'schema_version'"),
     "damaged: its schema_version 'abc' is not a number"),
    (_sql("DROP TABLE runs"), "damaged: an xcheck history without its runs table"),
    (_sql("DROP TABLE metrics"), "damaged: an xcheck history without its metrics table"),
])
def test_a_bad_history_exits_2_before_any_work_and_is_left_untouched(tmp_path, capsys, monkeypatch, make, words):
    """Refused before the run (no report folder either: the history is checked first), exit 2, the file
    untouched."""
    history = tmp_path / "h.sqlite"
    make(history)
    scenario = _scenario_copy(tmp_path)
    before = _files(tmp_path)
    code, err = _nightly_refused(capsys, monkeypatch, scenario, "--out", tmp_path / "reports", "--history", history)
    assert code == 2, err
    assert err.startswith(f"xcheck: error: {history}: ") and words in err, err
    assert "Traceback" not in err
    assert _files(tmp_path) == before


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="drops root's file-permission override (Linux)")
@pytest.mark.parametrize("file_mode, folder_mode, words", [
    (0o444, 0o755, "h.sqlite: it cannot be written (Permission denied)"),
    (0o644, 0o555, "its folder"),
    (None, 0o555, "its folder"),
], ids=["read-only file", "read-only folder", "new file in a read-only folder"])
def test_a_history_that_cannot_be_written_exits_2_before_any_work(tmp_path, file_mode, folder_mode, words):
    """Issue 24, item 1: found before the work (no report, ``latest`` not moved), not after it."""
    from xcheck.cli import main

    folder, out = tmp_path / "history", tmp_path / "reports"
    folder.mkdir()
    out.mkdir()
    history = folder / "h.sqlite"
    if file_mode is not None:
        _history_with_rows(history, rows=10)
        os.chmod(history, file_mode)
    os.chmod(folder, folder_mode)
    before = _files(folder)
    try:
        code, err = as_a_user(lambda: main(["nightly", "--quick", "--workers", "1", SCENARIO, "--out", str(out),
                                             "--history", str(history)]))
    finally:
        os.chmod(folder, 0o755)
    assert code == 2, err
    assert err.startswith(f"xcheck: error: {history}: ") and words in err and "cannot be written" in err, err
    assert list(out.iterdir()) == [] and _files(folder) == before


def test_bad_arguments_exit_2_naming_them(tmp_path, capsys, monkeypatch):
    cases = [(["--keep", "0"], "--keep: expected a positive number"),
             (["--baseline", "3"], "--baseline 3: the history"),
             (["--mujoco", "4.x"], "--mujoco: '4.x' is not a release number"),
             (["--mujoco", "04.0.0"], "--mujoco: '04.0.0' is not a release number"),
             (["--mujoco", "3.2.7,,"], "--mujoco: an empty item in '3.2.7,,'"),
             (["--speed-drop", "1.5"], "--speed-drop: expected a positive number at most 1, got 1.5"),
             (["--error-factor", "-1"], "--error-factor: expected a positive number, got -1.0"),
             (["--history", tmp_path / "missing" / "h.sqlite"], "does not exist"),
             (["--history", ""], "--history: expected a SQLite file or a postgresql:// URL, got an empty string")]
    for extra, words in cases:
        code, err = _nightly_refused(capsys, monkeypatch, _scenario_copy(tmp_path), "--out", tmp_path / "r", *extra)
        assert code == 2 and words in err and "Traceback" not in err, (extra, err)
        assert not (tmp_path / "r").exists() or not list((tmp_path / "r").iterdir()), extra  # nothing written


def test_two_nightlies_at_once_both_land(tmp_path):
    out = tmp_path / "reports"
    procs = [_nightly(_scenario_copy(tmp_path), "--out", out, popen=True) for _ in range(2)]
    for p in procs:
        stdout, stderr = p.communicate(timeout=300)
        assert p.returncode == 0, stdout + stderr
    with H.open_history(out / "history.sqlite", read_only=True) as hist:
        runs = hist.runs()
        assert len(runs) == 2
        assert len(hist.metrics(runs[0]["id"])) == len(hist.metrics(runs[1]["id"])) > 100
    assert {r["report"] for r in runs} == {str(p.resolve()) for p in out.iterdir() if re.match(r"\d{8}T", p.name)}


def test_baseline_run_id_compares_with_that_run(series):
    """Run 2 of :func:`series`, ``--baseline 1``, is compared with run 1; ``--baseline 7`` is refused naming the
    runs there are."""
    results = series["results"][2]
    assert results["history"][0]["baseline"] == "run 1" and results["history"][0]["baseline_runs"] == [1]
    proc = series["procs"]["baseline 7"]
    assert proc.returncode == 2 and "--baseline 7: no such run" in proc.stderr and "runs 1-2" in proc.stderr


def _fake_report(root: Path, name: str, results=True) -> Path:
    p = root / name
    p.mkdir()
    if results:
        (p / "results.json").write_text("{}")
    return p


def test_keep_deletes_only_older_report_folders(tmp_path):
    """Truth: by construction. Kept: the newest N stamp-named report folders, the one ``latest`` points to
    (here an old one), and everything that is not a report folder."""
    root = tmp_path
    old = [_fake_report(root, f"2026110{d}T020000Z") for d in range(1, 6)]
    second = _fake_report(root, "20261105T020000Z-2")
    not_reports = [_fake_report(root, "20261101T010000Z", results=False), _fake_report(root, "notes"),
                   _fake_report(root, "mujoco-3.2.7")]
    (root / "history.sqlite").write_bytes(b"x")
    (root / "latest").symlink_to(old[0].name)
    removed = nightly.keep_newest(root, 2)
    assert sorted(p.name for p in removed) == sorted(p.name for p in old[1:4])
    left = {p.name for p in root.iterdir()}
    assert {second.name, old[4].name, old[0].name, "latest", "history.sqlite"} | {p.name for p in not_reports} == left


def test_two_nightlies_pruning_at_once_name_only_what_each_removed(tmp_path, monkeypatch):
    """Issue 37, 7: concurrent `nightly --keep 1` runs each printed folders the other had deleted. Here the other
    nightly takes the oldest folder away between this one's listing and its own removal: this one skips it and
    returns only the folder it removed; nothing of either is left behind."""
    from pathlib import Path

    root = tmp_path
    old = [_fake_report(root, f"2026110{d}T020000Z") for d in range(1, 4)]
    rename = Path.rename

    def other_nightly_first(self, target):
        if self.name == old[0].name:
            shutil.rmtree(self)  # the other nightly's removal, just before this one's
        return rename(self, target)

    monkeypatch.setattr(Path, "rename", other_nightly_first)
    removed = nightly.keep_newest(root, 1)
    assert [p.name for p in removed] == [old[1].name]
    assert sorted(p.name for p in root.iterdir()) == [old[2].name]


def test_keep_on_the_command_line(series):
    """Three runs of :func:`series` with ``--keep 2``: the two newest report folders are kept, ``latest`` the last;
    the history keeps every run."""
    out = series["out"]
    reports = sorted(p.name for p in out.iterdir() if re.match(r"\d{8}T", p.name))
    assert len(reports) == 2 and (out / "latest").resolve().name == reports[-1]
    with H.open_history(out / "history.sqlite", read_only=True) as hist:
        assert len(hist.runs()) == 3  # the history keeps every run


def test_a_killed_nightly_records_nothing_and_leaves_the_history_readable(tmp_path, series):
    """A history of one run (:func:`series` after its run 1, copied), then a nightly interrupted while its studies
    run: exit 130, the history byte for byte as it was, one run."""
    out = tmp_path / "reports"
    out.mkdir()
    for name, data in series["after_run_1"].items():
        (out / name).write_bytes(data)
    before = (out / "history.sqlite").read_bytes()
    p = _nightly(_scenario_copy(tmp_path), "--out", out, "--workers", "2", popen=True)  # (the last --workers counts)
    from test_abuse import _children, _wait_for

    # the studies running: the worker pool starts once the command's imports are done and Ctrl-C is handled
    # (a fixed sleep was too short on a loaded machine: the interrupt landed during the imports). Pool workers
    # only: a passing `uname` (platform, at import) is a child too
    def pool_workers():
        found = []
        for w in _children(p.pid):
            try:
                if b"spawn_main" in Path(f"/proc/{w}/cmdline").read_bytes():
                    found.append(w)
            except OSError:
                pass
        return found

    assert _wait_for(pool_workers, timeout=60, step=0.05)
    import time

    time.sleep(0.5)  # past the moment the workers start, while the parent ignores Ctrl-C (xcheck.base.pool)
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=120)
    assert p.returncode == 130
    assert (out / "history.sqlite").read_bytes() == before
    with H.open_history(out / "history.sqlite", read_only=True) as hist:
        assert len(hist.runs()) == 1


# -----------------------------------------------------------------------------------------------------
# the MuJoCo version matrix
# -----------------------------------------------------------------------------------------------------
from conftest import OLD_MUJOCO  # noqa: E402


def test_the_version_matrix_runs_each_release_and_reports_the_uninstallable(tmp_path, package_index):
    """Truth: MuJoCo's changelog and a measurement, the gyroscope's RK4 is order 2 in 3.2.7 (the gyroscopic term
    of free bodies explicit) and order 4 in the installed release; 2.2.0 is on the index with no wheel for any Python
    xcheck runs on (its source alone: MuJoCo is not built here)."""
    from xcheck.history.matrix import installed_mujoco

    installed = installed_mujoco()
    out = tmp_path / "reports"
    proc = _nightly(_scenario_copy(tmp_path), "--out", out, "--mujoco", f"{installed},{OLD_MUJOCO},2.2.0")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "MuJoCo 2.2.0: cannot be installed" in proc.stdout
    assert f"MuJoCo {OLD_MUJOCO}: some checks failed" in proc.stdout
    with H.open_history(out / "history.sqlite", read_only=True) as hist:
        runs = {r["environment"]: r for r in hist.runs()}
        assert set(runs) == {"", f"mujoco=={OLD_MUJOCO}"}
        assert runs[f"mujoco=={OLD_MUJOCO}"]["mujoco"] == OLD_MUJOCO and runs[""]["mujoco"] == installed
        orders = {env: hist.metrics(r["id"])[(SCENARIO, "mujoco-rk4", None, "observed_order")]
                  for env, r in runs.items()}
    assert orders[f"mujoco=={OLD_MUJOCO}"] == pytest.approx(2.0, abs=0.1)
    assert orders[""] == pytest.approx(4.0, abs=0.1)
    report = (out / "latest" / "report.md").read_text()
    assert "## MuJoCo versions" in report and "**MuJoCo 2.2.0: **cannot be installed" in report
    row = next(line for line in report.splitlines() if line.startswith("| mujoco-rk4 |") and "p=2.0" in line)
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1].startswith("p=2.00") and cells[2].startswith("✅ p=4.00")  # better than its left neighbour
    assert (out / f"mujoco-{OLD_MUJOCO}" / "latest" / "results.json").is_file()


# -----------------------------------------------------------------------------------------------------
# PostgreSQL
# -----------------------------------------------------------------------------------------------------
def _pg_bin(name):
    found = shutil.which(name)
    if found:
        return found
    for p in sorted(Path("/usr/lib/postgresql").glob(f"*/bin/{name}"), reverse=True):
        return str(p)
    return None


@pytest.fixture(scope="module")
def postgres():
    """A PostgreSQL server of our own in a temporary folder (as user ``postgres`` when the tests run as root);
    skipped, and said so, when PostgreSQL or the psycopg driver is not installed."""
    pytest.importorskip("psycopg", reason="the postgres extra (psycopg) is not installed")
    initdb, pg_ctl = _pg_bin("initdb"), _pg_bin("pg_ctl")
    if not (initdb and pg_ctl):
        pytest.skip("PostgreSQL's initdb and pg_ctl are not installed: the PostgreSQL history is not tested")
    import tempfile

    # not under pytest's temporary folder: its parents are private to the user running the tests
    folder = Path(tempfile.mkdtemp(prefix="xcheck-pg-"))
    data, sock = folder / "data", folder / "sock"
    sock.mkdir()
    as_user = []
    if os.geteuid() == 0:  # PostgreSQL refuses to run as root
        import pwd

        try:
            pw = pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("running as root without a postgres user: cannot start a PostgreSQL server")
        shutil.chown(folder, pw.pw_uid, pw.pw_gid)
        shutil.chown(sock, pw.pw_uid, pw.pw_gid)
        as_user = ["runuser", "-u", "postgres", "--"]
    port = 54000 + os.getpid() % 1000
    for cmd in ([initdb, "-D", str(data), "-U", "xcheck", "--auth=trust", "-E", "UTF8"],
                [pg_ctl, "-D", str(data), "-w", "-l", str(folder / "log"), "-o",
                 f"-k {sock} -p {port} -c listen_addresses=''", "start"]):
        proc = subprocess.run([*as_user, *cmd], capture_output=True, text=True)
        if proc.returncode != 0:
            shutil.rmtree(folder, ignore_errors=True)
            pytest.fail(f"{' '.join(cmd[:1])} failed: {proc.stderr or proc.stdout}")
    try:
        yield f"postgresql://xcheck@/postgres?host={sock}&port={port}"
    finally:
        subprocess.run([*as_user, pg_ctl, "-D", str(data), "-m", "immediate", "stop"], capture_output=True)
        shutil.rmtree(folder, ignore_errors=True)


def test_a_postgresql_history(tmp_path, postgres):
    """Two nightlies into a PostgreSQL history: both recorded with the same figures as a SQLite history gets."""
    out = tmp_path / "reports"
    for n in (1, 2):
        proc = _nightly(_scenario_copy(tmp_path), "--out", out, "--history", postgres)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert f"nightly: run {n} recorded in postgresql://xcheck@/postgres" in proc.stdout
    doc = json.loads((out / "latest" / "results.json").read_text())
    assert doc["history"][0]["previous_run"] == 1
    with H.open_history(postgres) as pg, H.open_history(tmp_path / "h.sqlite") as lite:
        lite_run = lite.record(doc, started="s", finished="f")
        stored = pg.metrics(pg.runs()[-1]["id"])
        assert stored == lite.metrics(lite_run)  # doubles stored as doubles
        assert [r["id"] for r in pg.runs()] == [1, 2]


def test_a_foreign_postgresql_database_is_refused_untouched(postgres):
    import psycopg

    url = postgres.replace("/postgres?", "/other?")
    with psycopg.connect(postgres, autocommit=True) as con:
        con.execute("DROP DATABASE IF EXISTS other")
        con.execute("CREATE DATABASE other")
    with psycopg.connect(url, autocommit=True) as con:
        con.execute("CREATE TABLE runs (id INTEGER)")
    with pytest.raises(H.HistoryError, match="not an xcheck history"):
        H.open_history(url)
    with psycopg.connect(url, autocommit=True) as con:
        tables = {r[0] for r in con.execute("SELECT table_name FROM information_schema.tables "
                                            "WHERE table_schema = 'public'")}
    assert tables == {"runs"}


def test_bench_rows_are_recorded(tmp_path):
    """``--bench``: every benchmark row is stored as ``bench_steps_per_second``, equal to the report's own row. The
    optional engines left out (``$XCHECK_WITHOUT``): their rows are rows like any other, and cost 6 s here."""
    from xcheck.engines import ENGINES, WITHOUT_VARIABLE

    out = tmp_path / "reports"
    optional = ",".join(name for name in ENGINES if name != "mujoco")
    proc = _nightly(_scenario_copy(tmp_path), "--out", out, "--bench", env={**os.environ, WITHOUT_VARIABLE: optional})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = json.loads((out / "latest" / "results.json").read_text())["throughput"]
    reported = {(r["scenario"], r["method"] + (f" x{r['batch']}" if r["batch"] > 1 else "")): r["steps_per_second"]
                for r in rows}
    with H.open_history(out / "history.sqlite", read_only=True) as hist:
        stored = {k[:2]: v for k, v in hist.metrics(1).items() if k[3] == "bench_steps_per_second"}
    assert len(stored) >= 10 and any(" x" in m for _, m in stored)  # single and batch rows
    for key, value in stored.items():
        assert reported[key] == value


def test_a_second_maker_of_an_environment_waits_for_the_first(tmp_path):
    """Two processes wanting the same release's environment (two nightlies, two test files): the second waits on the
    first's lock and then finds it made, instead of installing MuJoCo a second time."""
    from xcheck.history import matrix

    env = tmp_path / "mujoco-envs" / "py-mujoco-9.9.9"
    env.parent.mkdir(parents=True)
    waiter = ("import sys, time; from pathlib import Path; from xcheck.history import matrix; env = Path(sys.argv[1]); "
              "t0 = time.monotonic()\nwith matrix._making(env):\n    print(f'{time.monotonic() - t0:.2f}', "
              "(env / '.ready').is_file())")
    with matrix._making(env):
        proc = subprocess.Popen([sys.executable, "-c", waiter, str(env)], stdout=subprocess.PIPE, text=True)
        time.sleep(1.0)
        assert proc.poll() is None  # still waiting for the lock
        env.mkdir()
        (env / ".ready").write_text("9.9.9\n")
    out, _ = proc.communicate(timeout=60)
    _, ready = out.split()
    # it saw the environment made: written while this process held the lock, so it had waited for the lock (its wait in
    # seconds is printed, not asserted: its interpreter's start-up, before its clock starts, varies by machine)
    assert ready == "True"
