"""``xcheck bench``: rows come from the runner registry, every runner on both bench scenarios, batch rows exactly
for the runners with a batch path, an engine's own rows, and the JSON schema."""

import json
import math

from xcheck.bench import BENCH_SCENARIOS, run_bench
from xcheck.cli import main
from xcheck.runners import RUNNERS


def test_rows_follow_the_runner_registry():
    methods = ["lie-cf4", "scipy-rk45", "mujoco-rk4", "mujoco-euler"]
    rows = run_bench(quick=True, repeat=1, batch=16, methods=methods)
    single = {(r["method"], r["scenario"]) for r in rows if r["batch"] == 1}
    assert {(m, s) for m in methods for s in BENCH_SCENARIOS} <= single
    batched = {r["method"] for r in rows if r["batch"] > 1 and "cells_per_second" not in r}
    assert batched == {m for m in methods if RUNNERS[m].run_batch is not None} == {"lie-cf4"}
    # a sweep's unit of work, for the sweep methods asked for: 10 cells, each a whole cross-check at one step
    (cells,) = [r for r in rows if "cells_per_second" in r]
    assert cells["method"] == "mujoco-rk4 (sweep cells)" and cells["batch"] == 10
    assert math.isfinite(cells["cells_per_second"]) and cells["cells_per_second"] > 0
    assert ("mujoco-rk4 (mj_step loop)", "gyroscope-nonsingular") in single  # the engine's own row
    assert all(r["engine"] == RUNNERS[r["method"].split(" ")[0]].engine for r in rows)
    assert all(math.isfinite(r["steps_per_second"]) and r["steps_per_second"] > 0 for r in rows)
    # only engines whose runners were asked for add rows
    assert not any("mj_step" in r["method"] for r in run_bench(quick=True, repeat=1, batch=4, methods=["lie-cf4"]))


def test_bench_cli_writes_json_and_refuses_unknown_methods(tmp_path, capsys):
    out = tmp_path / "b.json"
    assert main(["bench", "--quick", "--repeat", "1", "--methods", "formulation-2", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["schema"] == "xcheck.bench/1" and "mujoco" in doc["versions"]
    assert {(r["method"], r["batch"]) for r in doc["results"]} == {("formulation-2", 1), ("formulation-2", 1000)}
    assert main(["bench", "--methods", "nonesuch"]) == 2
    assert "--methods: unknown method 'nonesuch'" in capsys.readouterr().err


def test_bench_times_every_determination_method():
    """Every method of xcheck.determination.methods gets a row (solutions per second, one call on the whole stack)."""
    from xcheck.bench import _determination_rows
    from xcheck.determination.methods import METHODS

    rows = _determination_rows(500, 1)
    assert [r["method"] for r in rows] == [f"{m} (determination)" for m in METHODS]
    assert all(r["batch"] == 500 and r["solutions_per_second"] == r["steps_per_second"] > 0 for r in rows)


def test_ratios_are_taken_against_mujocos_fastest_rk4_row():
    """Truth: made-up rows; the slower of MuJoCo's two RK4 rows is never the denominator."""
    from xcheck.bench import fastest_mujoco_rk4, ratio_lines

    def row(engine, method, sps, batch=1):
        return {"engine": engine, "method": method, "scenario": "gyroscope-nonsingular", "batch": batch,
                "steps_per_second": sps}

    rows = [row("mujoco", "mujoco-rk4", 1.3e5), row("mujoco", "mujoco-rk4 (mj_step loop)", 1.8e5),
            row("mujoco", "mujoco-euler", 5e5), row("xcheck", "lie-rkmk4", 7.2e6), row("xcheck", "lie-rkmk4", 2e7, 10000)]
    assert fastest_mujoco_rk4(rows)["method"] == "mujoco-rk4 (mj_step loop)"
    lines = ratio_lines(rows)
    assert "mujoco-rk4 (mj_step loop) (1.8e+05 steps/s)" in lines[0]
    assert len(lines) == 2 and lines[1].split() == ["lie-rkmk4", "40.0x"]
