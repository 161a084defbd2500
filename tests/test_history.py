"""The nightly history (issue 11): storing reports, refusing what is not a history, finding what changed."""

from __future__ import annotations

import copy
import json
import sqlite3
import subprocess
import sys

import pytest

from xcheck.history import store as H


@pytest.fixture(scope="module")
def report(bundled_quick_report):
    """A real quick report, the bundled scenarios' (computed once per pytest run, tests/conftest.py): (its
    results.json document, the file)."""
    proc, out = bundled_quick_report
    assert proc.returncode == 0, proc.stderr
    path = out / "latest" / "results.json"
    return json.loads(path.read_text()), path


def _record(hist, results, n=0, host="h1"):
    return hist.record(results, started=f"2026-11-{10 + n:02d}T00:00:00Z", finished=f"2026-11-{10 + n:02d}T00:01:00Z",
                       host=host)


def test_a_report_is_stored_and_read_back(tmp_path, report):
    """Truth: the golden quick report's own numbers, every run figure of every method."""
    with H.open_history(tmp_path / "h.sqlite") as hist:
        run = _record(hist, report[0])
        stored = hist.metrics(run)
        (row,) = hist.runs()
    sc = report[0]["scenarios"][0]
    method, m = next(iter(sc["methods"].items()))
    r0 = m["runs"][0]
    assert stored[(sc["scenario"], method, r0["dt"], "attitude_error")] == r0["attitude_error"]
    assert stored[(sc["scenario"], method, None, "observed_order")] == m["observed_order"]
    assert stored[(sc["scenario"], "", None, "passed")] == float(sc["passed"])
    n_runs = sum(sum(k in r and r[k] is not None for k in H.RUN_METRICS for r in mm["runs"])
                 for s in report[0]["scenarios"] for mm in s["methods"].values())
    assert sum(1 for k in stored if k[2] is not None) == n_runs
    assert row["mujoco"] == report[0]["versions"]["mujoco"] and row["passed"] == int(report[0]["passed"])


def test_schema_version_and_application_are_written(tmp_path, report):
    H.open_history(tmp_path / "h.sqlite").close()
    con = sqlite3.connect(tmp_path / "h.sqlite")
    assert dict(con.execute("SELECT key, value FROM xcheck_meta")) == {
        "application": "xcheck.history", "schema_version": str(H.SCHEMA_VERSION)}


def test_a_schema_1_history_is_upgraded_in_place(tmp_path, report):
    """A history written before sweeps (schema 1: no sweep_cells) keeps its runs and becomes schema 2 when
    next written; a read-only check leaves it at 1."""
    path = tmp_path / "h.sqlite"
    with H.open_history(path) as hist:
        _record(hist, report[0])
    con = sqlite3.connect(path)
    con.executescript("DROP TABLE sweep_cells; UPDATE xcheck_meta SET value = '1' WHERE key = 'schema_version';")
    con.close()
    with H.open_history(path, read_only=True) as hist:
        assert len(hist.runs()) == 1
    assert sqlite3.connect(path).execute("SELECT value FROM xcheck_meta WHERE key = 'schema_version'").fetchone() == ("1",)
    with H.open_history(path) as hist:
        _record(hist, report[0], n=1)
        assert len(hist.runs()) == 2
    con = sqlite3.connect(path)
    assert con.execute("SELECT value FROM xcheck_meta WHERE key = 'schema_version'").fetchone() == ("2",)
    assert con.execute("SELECT COUNT(*) FROM sweep_cells").fetchone() == (0,)


@pytest.mark.parametrize("make, words", [
    (lambda p: p.write_bytes(b"this is not a database at all, just some bytes " * 100), "not an xcheck history"),
    (lambda p: sqlite3.connect(p).execute("CREATE TABLE invoices (id INTEGER)").connection.commit(),
     "not an xcheck history (no xcheck_meta table; it has invoices)"),
    (lambda p: (H.open_history(p).close(), sqlite3.connect(p).execute(
        "UPDATE xcheck_meta SET value = '99' WHERE key = 'schema_version'").connection.commit()),
     "written by a newer xcheck (history schema 99"),
    (lambda p: p.mkdir(), "is a folder"),
])
def test_what_is_not_a_history_is_refused_untouched(tmp_path, make, words):
    path = tmp_path / "h.sqlite"
    make(path)
    before = sorted((p.name, p.read_bytes()) for p in tmp_path.rglob("*") if p.is_file())
    with pytest.raises(H.HistoryError, match="h.sqlite") as info:
        H.open_history(path)
    assert words in str(info.value)
    assert sorted((p.name, p.read_bytes()) for p in tmp_path.rglob("*") if p.is_file()) == before


def _patched(results, scenario, method, **changes):
    doc = copy.deepcopy(results)
    sc = next(s for s in doc["scenarios"] if s["scenario"] == scenario)
    m = sc["methods"][method]
    for key, value in changes.items():
        if key == "error_factor":
            for r in m["runs"]:
                if r.get("attitude_error") is not None:
                    r["attitude_error"] *= value
        else:
            m[key] = value
    return doc


def test_regressions_and_improvements_by_the_issue_rules(tmp_path, report):
    """An error x100 (above a 1e-12 floor), an order -0.5 and a check turned failing are regressions; the
    reverse are improvements; an error x5 or an order -0.2 are not."""
    sc = next(s for s in report[0]["scenarios"] if s["scenario"] == "gyroscope-nonsingular")
    rows = list(H.report_metrics({"scenarios": [sc]}))
    before = {(s, m, dt, k): v for s, m, dt, k, v in rows}
    after = dict(before)
    err_key = max((k for k in before if k[1] == "lie-rkmk4" and k[3] == "attitude_error"), key=before.get)
    small_key = max((k for k in before if k[1] == "formulation-2" and k[3] == "attitude_error"), key=before.get)
    assert before[err_key] > 1e-11 > 1e-12 == before[("gyroscope-nonsingular", "", None, "order_floor")]
    order_key = ("gyroscope-nonsingular", "formulation-2", None, "observed_order")
    check_key = next(k for k in before if k[3].startswith("check:") and before[k] == 1.0)
    after[err_key] *= 100
    after[small_key] *= 5
    after[order_key] -= 0.5
    after[("gyroscope-nonsingular", "lie-rkmk4", None, "observed_order")] -= 0.2
    after[check_key] = 0.0
    changes = H.compare(before, after)
    assert {(c.kind, c.method, c.regression) for c in changes} == {
        ("error", "lie-rkmk4", True), ("order", "formulation-2", True), ("check", check_key[3][6:], True)}
    assert {(c.kind, c.regression) for c in H.compare(after, before)} == {
        ("error", False), ("order", False), ("check", False)}
    line = next(c for c in changes if c.kind == "error").line()
    assert line.startswith("REGRESSION: gyroscope-nonsingular / lie-rkmk4 at dt = ") and "->" in line


def test_speed_counts_only_the_same_host_and_the_finest_step(tmp_path, report):
    with H.open_history(tmp_path / "h.sqlite") as hist:
        slow = copy.deepcopy(report[0])
        for s in slow["scenarios"]:
            for m in s["methods"].values():
                for r in m["runs"]:
                    if r.get("steps_per_second"):
                        r["steps_per_second"] *= 0.5
        _record(hist, report[0], 0, host="fast-host")
        other = H.baseline_metrics(hist, hist.runs(), host="another-host")
        same = H.baseline_metrics(hist, hist.runs(), host="fast-host")
    assert not any(k[3] == "steps_per_second" for k in other)
    after = {(s, m, dt, k): v for s, m, dt, k, v in H.report_metrics(slow)}
    speed = [c for c in H.compare(same, after) if c.kind == "speed"]
    assert speed and all(c.regression for c in speed)
    per_method = {(c.scenario, c.method) for c in speed}
    assert len(per_method) == len(speed)  # one line per method: its finest step only


def test_the_baseline_is_the_median_of_the_last_runs(tmp_path, report):
    with H.open_history(tmp_path / "h.sqlite") as hist:
        key = None
        for n, factor in enumerate([1.0, 1000.0, 2.0, 3.0]):
            doc = _patched(report[0], "gyroscope-nonsingular", "lie-rkmk4", error_factor=factor)
            run = _record(hist, doc, n)
            key = key or next(k for k in hist.metrics(run) if k[:2] == ("gyroscope-nonsingular", "lie-rkmk4")
                                and k[3] == "attitude_error")
        base = H.baseline_metrics(hist, hist.runs()[-3:])
        base_all = H.baseline_metrics(hist, hist.runs()[-7:])
    value = {s["scenario"]: s for s in report[0]["scenarios"]}["gyroscope-nonsingular"]["methods"]["lie-rkmk4"]
    v0 = next(r["attitude_error"] for r in value["runs"] if r["dt"] == key[2])
    assert base[key] == pytest.approx(3.0 * v0, rel=1e-12)  # median of 1000, 2, 3
    assert base_all[key] == pytest.approx(2.5 * v0, rel=1e-12)  # median of 1, 1000, 2, 3


def test_an_interrupted_writer_leaves_the_history_as_it_was(tmp_path, report):
    """A process killed inside its transaction, after SQLite wrote some of its pages into the file (its page cache
    made one page small, as a report of a dozen scenarios fills the default one): its journal is left (a hot
    journal); a read-only opening says so, and the next writer's opening rolls it back and holds the runs before it.
    (Before, a writer's opening checked through a read-only connection, which cannot roll a journal back: 'not an
    xcheck history, or it cannot be read: attempt to write a readonly database' after every killed nightly.)"""
    path = tmp_path / "h.sqlite"
    with H.open_history(path) as hist:
        _record(hist, report[0])
    before = path.read_bytes()
    script = f"""
import json, os, signal
from xcheck.history import store as H
hist = H.open_history({str(path)!r})
hist.con.execute("PRAGMA cache_size = 1")  # pages spill into the file before COMMIT
doc = json.loads(open({str(report[1])!r}).read())
original = hist.con.executemany
def killed(*args):
    original(*args)
    os.kill(os.getpid(), signal.SIGKILL)  # after the rows, before COMMIT
hist.con = type("C", (), {{"execute": hist.con.execute, "executemany": staticmethod(killed)}})()
hist.record(doc, started="s", finished="f")
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert proc.returncode == -9, proc.stderr
    journal = path.with_name(path.name + "-journal")
    assert journal.stat().st_size > 0 and path.read_bytes() != before  # the case: a hot journal, the file written
    with pytest.raises(H.HistoryError, match="a write to it was interrupted and its journal is left beside it"):
        H.open_history(path, read_only=True)
    with H.open_history(path) as hist:
        assert len(hist.runs()) == 1
    assert path.read_bytes()[100:] == before[100:]  # as it was (the header's change counters aside)


def test_two_writers_at_once_both_land(tmp_path, report):
    path = tmp_path / "h.sqlite"
    H.open_history(path).close()
    script = f"""
import json
from xcheck.history import store as H
doc = json.loads(open({str(report[1])!r}).read())
with H.open_history({str(path)!r}) as hist:
    for i in range(5):
        hist.record(doc, started=str(i), finished=str(i))
"""
    procs = [subprocess.Popen([sys.executable, "-c", script], stderr=subprocess.PIPE, text=True) for _ in range(2)]
    for p in procs:
        assert p.wait(timeout=120) == 0, p.stderr.read()
    with H.open_history(path) as hist:
        runs = hist.runs()
        assert len(runs) == 10
        assert len({len(hist.metrics(r["id"])) for r in runs}) == 1


@pytest.mark.parametrize("url, shown", [
    ("postgresql://ann:s3cret@db.example/xc", "postgresql://ann@db.example/xc"),
    ("postgresql://ann@/xc?host=/tmp&password=s3cret&port=5", "postgresql://ann@/xc?host=/tmp&password=***&port=5"),
    ("postgres://ann:s3cret@h/xc?password=s3cret", "postgres://ann@h/xc?password=***"),
])
def test_a_password_is_never_shown(url, shown):
    """Issue 24, item 12: in the credentials or in the query, and in a driver's message that repeats it."""
    assert H.display(url) == shown
    assert H.scrub("could not connect with password s3cret", url) == "could not connect with password ***"
