"""Running sweeps (issue 12): a small sweep end to end, cells applied to the base, --resume after an
interruption, identical results on every executor, the tidy table and the database, refusals."""

from __future__ import annotations

import csv
import json
import os
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from xcheck.cli import main
from xcheck.commands.sweeps import run_sweep
from xcheck.models import load_body
from xcheck.paths import BUNDLED_MODELS
from xcheck.scenario import resolve_scenario
from xcheck.study import run_study
from xcheck.base import executors as X
from xcheck.sweep import run as R
from xcheck.sweep import spec as S

SMALL = """
description = "a test sweep"
base = "gyroscope-nonsingular"
seed = 3
methods = ["lie-rkmk4", "formulation-2", "mujoco-rk4"]
[axes.rate_scale]
values = [0.5, 1.0]
[axes.attitude]
random = "so3"
count = 3
[axes.dt]
values = [0.015625, 0.0078125, 0.00390625]
"""
TIMING = ("wall_time", "steps_per_second", "repeats")  # how often a short run was timed varies


def _spec(tmp_path, text=SMALL, name="small.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _rows(folder):
    with open(folder / "results.csv", newline="") as f:
        return list(csv.DictReader(f))


def _untimed(rows):
    return [{k: v for k, v in r.items() if k not in TIMING} for r in rows]


def test_a_small_sweep_end_to_end(tmp_path, capsys):
    """Truth: the exact torque-free solution. Every cell is the study of its own scenario: the batched runs of
    our methods equal run_study's one-by-one runs of the same cell to 1e-9 relative; lie-rkmk4 is order 4 in
    every cell; torque free, the error does not depend on the initial attitude (left invariance)."""
    spec_path = _spec(tmp_path)
    assert main(["sweep", str(spec_path), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert "6 cells" in out and "cells/s" in out and "per cell (median)" in out
    folder = tmp_path / "out" / "small" / "latest"
    rows = _rows(folder)
    assert len(rows) == 6 * 3 * 3  # cell x method x step
    assert {"cell", "rate_scale", "attitude_w", "attitude_angle_deg", "method", "dt", "attitude_error",
            "observed_order", "verdict"} <= set(rows[0])
    spec = S.load_sweep(spec_path)
    records = [json.loads(line) for line in (folder / "cells.jsonl").read_text().splitlines()[1:]]
    assert [r["id"] for r in records] == [c["id"] for c in spec.cells]
    for rec in records:
        assert sorted(rec["batched"]) == ["formulation-2", "lie-rkmk4"]
        assert abs(rec["methods"]["lie-rkmk4"]["observed_order"] - 4) < 0.3
    # one cell against a study of its scenario, run the ordinary way
    cell = spec.cells[4]
    st = run_study(S.apply_cell(spec.base, cell["params"]), methods=spec.methods, steps=spec.steps, workers=1)
    rec = next(r for r in records if r["id"] == cell["id"])
    for m in spec.methods:
        got = [r["attitude_error"] for r in rec["methods"][m]["runs"]]
        want = [r.attitude_error for r in st.methods[m].runs]
        np.testing.assert_allclose(got, want, rtol=1e-9, err_msg=m)
    # left invariance: at each rate, the error is the same for every attitude (to round-off over 10 s)
    for scale in (0.5, 1.0):
        errs = [float(r["attitude_error"]) for r in rows if r["method"] == "lie-rkmk4" and r["dt"] == "0.015625"
                and float(r["rate_scale"]) == scale]
        assert len(errs) == 3 and max(errs) / min(errs) < 1.01, errs
    summary = json.loads((folder / "sweep.json").read_text())
    assert summary["cells"] == 6 and summary["cells_passed"] == 6 and summary["versions"]["mujoco"]
    html = (folder / "index.html").read_text()
    assert "6 of 6 cells passed every check" in html and html.count("<img") == 3


def test_the_database_has_the_history_tables_and_the_cells(tmp_path):
    """Truth: the CSV of the same sweep. Every run's attitude error is in metrics under <base>/<cell>, and the
    cells' parameters join with it."""
    assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0
    folder = tmp_path / "out" / "small" / "latest"
    con = sqlite3.connect(folder / "sweep.sqlite")
    assert dict(con.execute("SELECT key, value FROM xcheck_meta")) == {"application": "xcheck.history",
                                                                       "schema_version": "2"}
    (environment,) = con.execute("SELECT environment FROM runs").fetchone()
    assert environment == "sweep:small"
    joined = con.execute(
        "SELECT c.value, m.value FROM metrics m JOIN sweep_cells c ON c.run_id = m.run_id AND c.scenario = m.scenario "
        "WHERE m.method = 'formulation-2' AND m.metric = 'attitude_error' AND m.dt = 0.00390625 "
        "AND c.parameter = 'rate_scale' ORDER BY m.scenario").fetchall()
    rows = [r for r in _rows(folder) if r["method"] == "formulation-2" and r["dt"] == "0.00390625"]
    assert len(joined) == 6
    assert sorted(joined) == sorted((float(r["rate_scale"]), float(r["attitude_error"])) for r in rows)


def test_jobs_and_dask_give_identical_results(tmp_path):
    """Truth: --jobs 1. The same chunks run on two worker processes and on a Dask LocalCluster give the same
    table, every digit (wall times aside)."""
    pytest.importorskip("distributed", reason="the Dask executor needs the optional extra 'distributed'")
    spec_path = _spec(tmp_path)
    tables = []
    for k, extra in enumerate((["--jobs", "1"], ["--jobs", "2"], ["--executor", "dask", "--jobs", "2"])):
        assert main(["sweep", str(spec_path), "--out", str(tmp_path / f"out{k}"), *extra]) == 0
        tables.append(_untimed(_rows(tmp_path / f"out{k}" / "small" / "latest")))
    assert len(tables[0]) == 54
    assert tables[1] == tables[0]
    assert tables[2] == tables[0]


def test_resume_after_an_interruption_does_not_redo_finished_cells(tmp_path, monkeypatch):
    """An interrupt after the first chunk keeps its cells in the log and writes no folder; --resume runs only the
    others, and the result equals an uninterrupted sweep's."""
    spec = S.load_sweep(_spec(tmp_path))
    calls = []
    real = R.run_chunk

    def counting(chunk, methods, steps):
        calls.append([c[0] for c in chunk])
        return real(chunk, methods, steps)

    monkeypatch.setattr(R, "run_chunk", counting)

    def interrupt(done, total, label):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, tmp_path / "out", jobs=1, progress=interrupt, say=lambda s: None)
    root = tmp_path / "out" / "small"
    assert not (root / "latest").exists() and not list(root.glob("2*"))  # no folder, complete or not
    log = root / R.PARTIAL_LOG
    first = calls[0]
    assert len(log.read_text().splitlines()) == 1 + len(first)
    with open(log, "a") as f:
        f.write('{"id": "cut sho')  # a line cut short by a kill: dropped on reading
    calls.clear()
    notes = []
    done = run_sweep(spec, tmp_path / "out", jobs=1, resume=True, say=notes.append)
    ran = [cid for chunk in calls for cid in chunk]
    assert sorted(ran) == sorted(c["id"] for c in spec.cells if c["id"] not in first)
    assert done.reused == len(first) and done.ran == 6 - len(first)
    assert any("already done" in n for n in notes) and not log.exists()
    fresh = run_sweep(spec, tmp_path / "fresh", jobs=1, say=lambda s: None)
    assert _untimed(_rows(done.folder)) == _untimed(_rows(fresh.folder))
    # --resume of a complete sweep reads its latest folder and runs nothing
    calls.clear()
    again = run_sweep(spec, tmp_path / "out", jobs=1, resume=True, say=lambda s: None)
    assert calls == [] and again.reused == 6


@pytest.fixture(scope="module")
def _interrupted_log(tmp_path_factory):
    """The log of SMALL interrupted after its first chunk (made once: each test gets a copy)."""
    tmp = tmp_path_factory.mktemp("interrupted")
    path = _spec(tmp)

    def interrupt(done, total, label):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(S.load_sweep(path), tmp / "out", jobs=1, progress=interrupt, say=lambda s: None)
    return (tmp / "out" / "small" / R.PARTIAL_LOG).read_bytes()


@pytest.fixture
def interrupted_sweep(tmp_path, _interrupted_log):
    """A sweep interrupted after its first chunk: (spec path, the partial log, its bytes)."""
    log = tmp_path / "out" / "small" / R.PARTIAL_LOG
    log.parent.mkdir(parents=True)
    log.write_bytes(_interrupted_log)
    return _spec(tmp_path), log, _interrupted_log


def test_a_refused_run_keeps_an_interrupted_sweeps_cells(tmp_path, capsys, interrupted_sweep):
    """Issue 24, item 3: a run refused as its executor starts (a scheduler nobody answers at) discards nothing and
    says nothing of starting over; --resume then reruns only the cells not finished."""
    path, log, before = interrupted_sweep
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--executor", "dask",
                 "--scheduler", "tcp://127.0.0.1:9"]) == 2
    out = capsys.readouterr()
    assert "starting over" not in out.out + out.err and log.read_bytes() == before
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--resume", "--jobs", "1"]) == 0
    kept = len(before.decode().splitlines()) - 1
    assert f"--resume: {kept} of 6 cells already done; running {6 - kept}" in capsys.readouterr().out


def _record_line(log: Path) -> dict:
    return json.loads(log.read_text().splitlines()[1])


@pytest.mark.parametrize("damage, words", [
    (lambda log: log.write_bytes(bytes(range(256)) * 8), "not an xcheck sweep log (not UTF-8 text)"),
    (lambda log: log.write_text("[1, 2]\n"), "not an xcheck sweep log (its first line is not the header"),
    (lambda log: log.write_text(log.read_text() + "{}\n"), "not a cell's record (no 'id')"),
    (lambda log: log.write_text(log.read_text() + "42\n"), "not a cell's record (a JSON int, not an object)"),
    (lambda log: log.write_text(log.read_text() + "not json\n" + log.read_text().splitlines()[1] + "\n"),
     "not JSON"),
    (lambda log: log.write_text(log.read_text() + json.dumps(
        {k: v for k, v in _record_line(log).items() if k != "methods"}) + "\n"), "not a cell's record (no 'methods')"),
    (lambda log: log.write_text(log.read_text() + json.dumps(
        {**_record_line(log), "params": {"rate_scale": 7.0}}) + "\n"), "is not the digest of its params"),
    (lambda log: log.write_text(log.read_text().replace('"attitude_error": ', '"attitude_error": "x", "_": ', 1)),
     "attitude_error is 'x', not a number"),
], ids=["random bytes", "a list header", "{}", "42", "a bad line inside", "no methods", "foreign params",
        "a string for a number"])
def test_a_damaged_resume_log_is_refused_before_any_work(tmp_path, capsys, damage, words, interrupted_sweep):
    """Issue 24, item 5: exit 2 before any cell runs, naming the file (and the line), the file untouched."""
    path, log, _ = interrupted_sweep
    damage(log)
    before = log.read_bytes()
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--resume", "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert f"xcheck: error: {log}" in err and words in err, err
    assert log.read_bytes() == before and not list((tmp_path / "out" / "small").glob("2*"))


def test_jobs_beyond_the_cpus_are_capped(tmp_path, capsys):
    """Issue 24, item 2: --jobs 1000 on a 6-cell sweep starts no more workers than CPUs, and says so."""
    import os

    assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--jobs", "1000"]) == 0
    cpus = os.cpu_count()
    out = capsys.readouterr().out
    assert f"note: --jobs 1000: {cpus} worker processes, one per CPU" in out and f"on {cpus} process" in out


def test_resume_refuses_a_log_of_other_methods(tmp_path):
    spec = S.load_sweep(_spec(tmp_path))
    root = tmp_path / "out" / "small"
    root.mkdir(parents=True)
    (root / R.PARTIAL_LOG).write_text(json.dumps({"schema": R.LOG_SCHEMA, "fingerprint": "0" * 16}) + "\n")
    with pytest.raises(S.SweepError, match="another base scenario.*without --resume"):
        run_sweep(spec, tmp_path / "out", jobs=1, resume=True, say=lambda s: None)


def test_cells_are_applied_to_the_base(tmp_path):
    """Truth: the MJCF's own values, scaled or replaced by hand."""
    base = resolve_scenario("rax1-orbit-field")
    body = load_body(base.model)
    sc = S.apply_cell(base, {"dipole_scale": 2.0, "inertia_scale": 3.0, "rate_scale": 0.5,
                             "field.altitude_km": 500.0})
    np.testing.assert_allclose(sc.torque["dipole"], 2 * body.dipole, rtol=1e-15)
    np.testing.assert_allclose(sc.inertia, 3 * np.array(body.model_moments), rtol=1e-15)
    np.testing.assert_allclose(sc.omega0, 0.5 * base.omega0, rtol=1e-15)
    assert sc.torque["altitude_km"] == 500.0 and "dipole" not in (base.torque or {})  # the base is unchanged
    sc = S.apply_cell(base, {"rate_direction": [0.0, 0.0, 2.0], "attitude": [0.0, 1.0, 0.0, 0.0]})
    np.testing.assert_allclose(sc.omega0, [0, 0, np.linalg.norm(base.omega0)], rtol=1e-15)
    np.testing.assert_allclose(sc.q0, [0, 1, 0, 0])
    gyro = resolve_scenario("gyroscope-nonsingular")
    sc = S.apply_cell(gyro, {"model": str(base.model), "rate_deg": [10.0, 0.0, 0.0]})
    assert sc.model == base.model and np.allclose(sc.omega0, [np.radians(10), 0, 0])


def test_an_inertia_axis_reaches_mujoco(tmp_path):
    """Truth: the exact solution for the new inertia. MuJoCo runs the changed body, not the MJCF's: its RK4 is
    order 4 and its errors are those of our RKMK4 within a factor 1.5 at every step (with body_inertia written
    but its derived constants not recomputed, mj_setConst, the error was 4e-2 rad)."""
    text = """
base = "tumbler-intermediate-axis"
methods = ["lie-rkmk4", "mujoco-rk4"]
[axes.inertia]
values = [[2.0, 4.0, 3.9], [1.0, 1.5, 2.4]]
[axes.dt]
values = [0.0625, 0.03125, 0.015625, 0.0078125]
"""
    assert main(["sweep", str(_spec(tmp_path, text, "inertia.toml")), "--out", str(tmp_path / "out"),
                 "--jobs", "1"]) == 0
    rows = _rows(tmp_path / "out" / "inertia" / "latest")
    lie = {(r["cell"], r["dt"]): float(r["attitude_error"]) for r in rows if r["method"] == "lie-rkmk4"}
    mj = [r for r in rows if r["method"] == "mujoco-rk4"]
    assert len(mj) == 8
    for r in mj:
        assert abs(float(r["observed_order"]) - 4) < 0.3
        assert 1 / 1.5 < float(r["attitude_error"]) / lie[(r["cell"], r["dt"])] < 1.5, r
    assert max(float(r["attitude_error"]) for r in mj if r["dt"] == "0.0078125") < 1e-7


@pytest.mark.parametrize("axis, table, needle", [
    ("model", 'values = ["nope.xml"]', "no such file"),
    ("model", 'values = ["bad.xml"]', "MuJoCo could not load it"),
    ("inertia", "values = [[1.0, 1.0, 3.0]]", "triangle inequality"),
    ("field", 'values = ["uniform"]', "needs H_world"),
    ("dt", "values = [20.0]", "duration"),
])
def test_axis_values_the_base_cannot_take_are_refused(tmp_path, capsys, axis, table, needle):
    (tmp_path / "bad.xml").write_text("<mujoco><worldbody><body>")
    text = f'base = "rax1-orbit-field"\n[axes.{axis}]\n{table}\n'
    path = _spec(tmp_path, text, "refused.toml")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and f"[axes.{axis}]" in err and needle in err, err
    assert not (tmp_path / "out" / "refused").exists()  # refused before anything ran


@pytest.mark.parametrize("argv, needle", [
    (["--jobs", "0"], "--jobs"),
    (["--scheduler", "tcp://localhost:1"], "--scheduler: only with --executor dask"),
])
def test_bad_arguments(tmp_path, capsys, argv, needle):
    assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), *argv]) == 2
    assert needle in capsys.readouterr().err


def test_an_unreachable_scheduler_is_named(tmp_path, capsys):
    pytest.importorskip("distributed", reason="the Dask executor needs the optional extra 'distributed'")
    assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--executor", "dask",
                 "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "tcp://127.0.0.1:9" in capsys.readouterr().err


def test_a_scheduler_address_that_is_not_dask_is_named_within_seconds(tmp_path, capsys, monkeypatch):
    """Issue 24, item 4: a web server at the address accepts the connection and never speaks Dask: refused once
    SCHEDULER_SECONDS have passed (1 s here), naming the address; a real scheduler passes the same probe."""
    pytest.importorskip("distributed", reason="the Dask executor needs the optional extra 'distributed'")
    import threading
    from http.server import HTTPServer, SimpleHTTPRequestHandler

    from distributed import LocalCluster

    server = HTTPServer(("127.0.0.1", 0), SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    monkeypatch.setattr(X, "SCHEDULER_SECONDS", 1)
    address = f"tcp://127.0.0.1:{server.server_address[1]}"
    try:
        assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--executor", "dask",
                     "--scheduler", address]) == 2
    finally:
        server.shutdown()
    err = capsys.readouterr().err
    assert f"--scheduler {address}: something answers there, but not a Dask scheduler within 1 s" in err, err
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=":0") as cluster:
        X._is_a_scheduler(cluster.scheduler_address)  # nothing raised


def test_ctrl_c_in_a_dask_sweep_ends_it_promptly_and_quietly(tmp_path):
    """Issue 24, item 10: Ctrl-C while the LocalCluster starts (its workers importing) or while its workers
    compute: exit 130 within seconds, one line, no worker's traceback and no half-built cluster's at exit."""
    pytest.importorskip("distributed", reason="the Dask executor needs the optional extra 'distributed'")
    import os
    import signal
    import subprocess
    import sys
    import time

    spec = _spec(tmp_path, 'base = "gyroscope-nonsingular"\n[axes.rate_scale]\nrange = [0.5, 2.0]\nnum = 40\n',
                 "long.toml")
    # the cluster starting (its workers forked at 1.0-3 s, later on a loaded machine), then computing. A Ctrl-C
    # while a worker was forked was lost (2 in 8 at 2.5-3 s with both cores busy: SIGINT was ignored around each
    # fork); now the forking thread blocks it instead, and 10 in 10 ended. A Ctrl-C while the cluster starts waits
    # for the start to finish (a half-built cluster fails its own close): seconds, 6 s seen under full load.
    for delay in (1.5, 3.0):
        proc = subprocess.Popen([sys.executable, "-m", "xcheck", "sweep", str(spec), "--out", str(tmp_path / "out"),
                                 "--executor", "dask", "--jobs", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, start_new_session=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(delay)
        os.killpg(proc.pid, signal.SIGINT)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130 and "Traceback" not in err and "interrupted" in err, (delay, err)
        assert time.monotonic() - t0 < 20, (delay, time.monotonic() - t0, err)  # a hang, not a speed


def test_a_partial_log_that_is_a_folder_is_named(tmp_path, capsys):
    """Issue 24, item 12: the message names the log, not a temporary file beside it."""
    (tmp_path / "out" / "small" / R.PARTIAL_LOG).mkdir(parents=True)
    assert main(["sweep", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert f"{R.PARTIAL_LOG}: is a folder; expected a file" in err and ".tmp" not in err, err


def test_a_read_only_sweep_folder_is_named(tmp_path):
    """Issue 24, item 12: <out>/<spec>/ that cannot be written: its log is named, not a temporary file."""
    import os

    from permissions import as_a_user

    root = tmp_path / "out" / "small"
    root.mkdir(parents=True)
    os.chmod(root, 0o555)
    path = _spec(tmp_path)
    try:
        code, err = as_a_user(lambda: main(["sweep", str(path), "--out", str(tmp_path / "out"), "--jobs", "1"]))
    finally:
        os.chmod(root, 0o755)
    assert code == 2 and f"{root / R.PARTIAL_LOG}: Permission denied (writing it in {root})" in err, err
    assert ".tmp" not in err


def load_body_centre(model) -> float:
    """A top's centre of mass from its pivot [m] (the composite of disk and axle)."""
    import warnings

    from xcheck.models import load_body

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(np.linalg.norm(load_body(model).centre))


def test_bundled_sweeps_are_valid():
    """The example sweeps parse, with the cells their issues ask for."""
    from xcheck.paths import BUNDLED_MODELS

    specs = {p.stem: S.load_sweep(p) for p in sorted((BUNDLED_MODELS / "sweeps").glob("*.toml"))}
    assert set(specs) == {"rax1-dipole-inertia", "gyroscope-spin-dt", "model-swap", "heavy-top-nutation-dt",
                          "heavy-top-pivot-spin", "rax1-wheel-dipole"}
    wheel = specs["rax1-wheel-dipole"]  # issue 28: wheel momentum x dipole strength
    assert sorted({(c["params"]["wheel_speed_scale"], c["params"]["dipole_scale"]) for c in wheel.cells}) == [
        (w, d) for w in (0.001, 0.01, 0.1, 1.0) for d in (1.0, 10.0, 100.0)]
    pivots = {load_body_centre(c["params"]["model"]) for c in specs["heavy-top-pivot-spin"].cells}
    # the disk (2 kg) 1, 2, 4 cm above the pivot, the axle (0.02 kg) centred 1.5 cm above it
    np.testing.assert_allclose(sorted(pivots), [(2.0 * l + 0.02 * 0.015) / 2.02 for l in (0.01, 0.02, 0.04)], rtol=1e-12)
    top = specs["heavy-top-nutation-dt"]  # issue 27: the nutation angle x step on the ball joint
    angles = sorted(2 * np.degrees(np.arccos(c["params"]["attitude"][0])) for c in top.cells)
    np.testing.assert_allclose(angles, [1, 5, 15, 30, 60, 90], atol=1e-9)
    assert len(specs["rax1-dipole-inertia"].cells) == 100
    assert specs["gyroscope-spin-dt"].methods == ["mujoco-rk4", "mujoco-euler", "mujoco-implicit",
                                                  "mujoco-implicitfast"]
    swap = specs["model-swap"]
    assert len(swap.cells) == 300 and len({c["params"]["model"] for c in swap.cells}) == 3


def test_a_bundled_sweep_runs_by_name(tmp_path, capsys):
    """`xcheck sweep NAME` finds a bundled sweep (an installed xcheck has no models/ folder at hand); `xcheck list`
    names them; an unknown name is refused with the bundled names."""
    assert main(["list"]) == 0
    assert "gyroscope-spin-dt" in capsys.readouterr().out
    assert main(["sweep", "no-such-sweep", "--out", str(tmp_path)]) == 2
    assert ("not a bundled sweep (gyroscope-spin-dt, heavy-top-nutation-dt, heavy-top-pivot-spin, model-swap, "
            "rax1-dipole-inertia, rax1-wheel-dipole)" in capsys.readouterr().err)
    spec = S.resolve_sweep("gyroscope-spin-dt")
    assert spec.path.name == "gyroscope-spin-dt.toml" and len(spec.cells) == 8


def test_a_torques_axis_runs_and_reports_each_set_of_terms(tmp_path, capsys):
    """Issue 37, 1: the documentation's own `torques` axis ran every cell and then crashed (a list of kinds read
    as a vector). Truth: with no term kept the body is torque free, so its angular momentum in the world is
    conserved — lie-rkmk4 keeps it to 1e-12 relative at 1/128 s — and only that cell has invariants to report."""
    spec = _spec(tmp_path, """
base = "rax1-momentum-bias"
methods = ["lie-rkmk4", "mujoco-rk4"]
[axes.torques]
values = [["magnetic"], ["magnetic", "gravity-gradient"], []]
[axes.dt]
values = [0.015625, 0.0078125]
""", name="terms.toml")
    assert main(["sweep", str(spec), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0
    assert "3 of 3 cells passed" in capsys.readouterr().out
    rows = [r for r in _rows(tmp_path / "out" / "terms" / "latest") if r["method"] == "lie-rkmk4"]
    assert [r["torques"] for r in rows] == ["magnetic"] * 2 + ["magnetic+gravity-gradient"] * 2 + ["none"] * 2
    for r in rows:
        assert (r["momentum_change"] != "") == (r["torques"] == "none"), r
    assert abs(float(rows[-1]["momentum_change"])) < 1e-12 and float(rows[-1]["momentum_turn"]) < 1e-12


@pytest.mark.parametrize("base, axes, needle", [
    ("gyroscope-nonsingular", "[axes.rate_scale]\nvalues = [1.0, 1e308]", "rate_scale = 1e+308"),
    ("gyroscope-nonsingular", "[axes.rate]\nvalues = [[1e300, 0, 0]]", "|omega| = 1e+300 rad/s"),
    ("gyroscope-nonsingular", "[axes.rate_deg]\nvalues = [[1e300, 0, 0]]", "rate_deg = [1e+300, 0.0, 0.0]"),
    ("rax1-momentum-bias", "[axes.wheel_speed_scale]\nvalues = [1e300]", "wheel_speed_scale = 1e+300"),
    ("gyroscope-nonsingular", 'combine = "sample"\nsamples = 3\n[axes.rate_scale]\nrange = [1, 1e308]',
     "starts from no state a body can have"),
])
def test_cells_that_start_from_no_body_state_are_refused_before_any_runs(tmp_path, capsys, base, axes, needle):
    """Issue 37, 4: overflowing scales ran the sweep and crashed (exit 3) in the cells or after them."""
    if axes.startswith("combine"):
        head, _, axes = axes.partition("[axes")
        text, axes = f'base = "{base}"\n{head}', "[axes" + axes
    else:
        text = f'base = "{base}"\n'
    path = _spec(tmp_path, text + axes + "\n", "overflow.toml")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and needle in err and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()


def test_a_rate_direction_of_any_length_is_a_direction():
    """[1e-320, 0, 0] (whose norm underflows) and [1e308, 1e308, 0] (whose norm overflows) are directions: the cell's
    rate keeps the base's magnitude along them."""
    base = resolve_scenario("gyroscope-nonsingular")
    for d, unit in (([1e-320, 0, 0], [1, 0, 0]), ([1e308, 1e308, 0], [2 ** -0.5, 2 ** -0.5, 0])):
        sc = S.apply_cell(base, {"rate_direction": d})
        np.testing.assert_allclose(sc.omega0, np.linalg.norm(base.omega0) * np.array(unit), rtol=1e-15)


@pytest.mark.parametrize("base, axes, needle", [
    ("rax1-momentum-bias", f'[axes.model]\nvalues = ["{BUNDLED_MODELS / "rax1.xml"}"]',
     "[initial] wheel_speeds: the model"),
    ("gyrostat-axisymmetric", f'[axes.model]\nvalues = ["{BUNDLED_MODELS / "tumbler_wheels.xml"}"]',
     "expected 3 finite speeds"),
    ("heavy-top", "[axes.inertia]\nvalues = [[0.003, 0.004, 0.005]]", "built from 2 parts"),
    ("heavy-top", "[axes.inertia_scale]\nvalues = [1.0, 2.0]", "built from 2 parts"),
])
def test_cells_that_cannot_run_are_refused_when_the_spec_is_read(tmp_path, capsys, base, axes, needle):
    """Issue 37, 6: a model axis that drops a gyrostat's wheels, or gives it other wheels, failed per cell at run
    time; an inertia axis on a body built from parts changed MuJoCo's first part only (0.46 rad "disagreement" on an
    asymmetric heavy top whose axle kept its own inertia)."""
    path = _spec(tmp_path, f'base = "{base}"\n{axes}\n', "cannot.toml")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and needle in err, err
    assert not (tmp_path / "out").exists()


def test_a_second_sweep_into_a_live_ones_folder_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    """Issue 37, 7: two sweeps into one --out lost cells (the second deleted the first's live log as an interrupted
    run's). The first's hold (here taken by hand, as a live run holds it) refuses the second, naming the holder; the
    first's log is untouched; once it ends the folder is free."""
    from xcheck.base.files import held_alone

    root = tmp_path / "out" / "small"
    root.mkdir(parents=True)
    (root / R.PARTIAL_LOG).write_text("the first run's cells\n")
    monkeypatch.setattr(R, "executor", lambda *a, **k: pytest.fail("work started before the refusal"))
    path = _spec(tmp_path)
    with held_alone(root, "--out"):
        assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert f"--out: {root} is in use by xcheck process {os.getpid()}" in err, err
    assert (root / R.PARTIAL_LOG).read_text() == "the first run's cells\n"
    monkeypatch.undo()
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0
