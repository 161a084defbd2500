"""The newer commands under generated abuse (issue 24, "Keeping it true"): sweep specs (axes, ranges,
distributions, sizes), ``[determination]`` tables, nightly histories damaged at random pages, and ``--resume``
logs cut, corrupted or foreign. Whatever comes in: exit 0, 1 or 2, never a traceback, a sweep refused before it
allocates, and nothing on disk lost (a history or a sweep log refused is left as it was; one accepted keeps its
earlier runs and cells).

Derandomized and bounded (small bodies, short runs, ``--max-cells`` small) so that the suite stays quick; set
``XCHECK_FUZZ_EXAMPLES`` to run every property longer by hand."""

from __future__ import annotations

import json
import math
import os
import shutil
import sqlite3
import tracemalloc

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_cli_fuzz import to_toml  # noqa: E402  (the same TOML writer)

from xcheck.cli import main
from xcheck.paths import BUNDLED_MODELS
from xcheck.sweep import spec as S

EXAMPLES = int(os.environ.get("XCHECK_FUZZ_EXAMPLES", "0"))


def _settings(n):
    return settings(max_examples=EXAMPLES or n, deadline=None, derandomize=True,
                    suppress_health_check=list(HealthCheck))


GYRO = (BUNDLED_MODELS / "gyroscope.xml").as_posix()
RAX1 = (BUNDLED_MODELS / "rax1.xml").as_posix()
#: A small magnetic scenario: every axis of a sweep applies to it, and its runs take milliseconds.
BASE = f'''name = "fuzzbase"
model = "{RAX1}"
duration = 1.0
[initial]
quaternion = [1.0, 0.0, 0.0, 0.0]
angular_velocity_deg = [10.0, -5.0, 3.0]
[torque]
kind = "magnetic"
field = "orbit-dipole"
[study]
reference = "dop853"
steps = [0.25, 0.125]
quick_steps = [0.25, 0.125]
methods = ["lie-rkmk4", "formulation-2"]
'''

special = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, 0.0, -0.0, 1e-12, 1e12, 1e300,
                           -1.0, 1e30, 1e9])
numbers = st.one_of(special, st.floats(-5, 5, allow_nan=False), st.integers(-3, 10**12))
anything = st.one_of(numbers, st.booleans(), st.text(max_size=6), st.lists(numbers, max_size=4))
vectors = st.one_of(st.lists(numbers, min_size=3, max_size=4), anything)
AXES = ["dipole_scale", "inertia_scale", "rate_scale", "rate_direction", "attitude", "rate", "dipole", "inertia",
        "field.altitude_km", "field.inclination_deg", "dt", "model", "colour"]


@st.composite
def axis_tables(draw, name):
    kind = draw(st.sampled_from(["values", "range", "random", "normal", "junk"]))
    if kind == "values":
        vals = draw(st.lists(vectors if name in ("rate_direction", "attitude", "rate", "dipole", "inertia")
                             else numbers, min_size=0, max_size=3))
        if name == "model":
            vals = draw(st.lists(st.sampled_from([GYRO, RAX1, "missing.xml"]), max_size=2))
        return {"values": vals}
    if kind == "range":
        table = {"range": draw(st.lists(numbers, min_size=1, max_size=3)),
                 "num": draw(st.one_of(st.integers(-2, 6), st.sampled_from([1000, 10**9]), special))}
        if draw(st.booleans()):
            table["spacing"] = draw(st.sampled_from(["linear", "log", "cubic"]))
        if draw(st.booleans()):
            table["distribution"] = draw(st.sampled_from(["uniform", "log-uniform", "normal"]))
        return table
    if kind == "random":
        return {"random": draw(st.sampled_from(["so3", "sphere", "cube"])),
                "count": draw(st.one_of(st.integers(-1, 4), st.sampled_from([10**6, 10**9])))}
    if kind == "normal":
        return {"mean": draw(numbers), "std": draw(numbers)}
    return draw(st.dictionaries(st.text(max_size=5), anything, max_size=2))


@st.composite
def sweep_specs(draw):
    doc = {"base": "base.toml"}
    if draw(st.booleans()):
        doc["combine"] = draw(st.sampled_from(["product", "sample", "zip"]))
    if doc.get("combine") == "sample" or draw(st.integers(0, 5)) == 0:
        doc["samples"] = draw(st.one_of(st.integers(-1, 6), st.sampled_from([10**9]), special))
    if draw(st.booleans()):
        doc["seed"] = draw(st.one_of(st.integers(-5, 2**70), special))
    axes = {}
    for name in draw(st.lists(st.sampled_from(AXES), min_size=draw(st.sampled_from([0, 1, 1, 1])), max_size=3,
                              unique=True)):
        axes[name] = draw(axis_tables(name))
    doc["axes"] = axes
    return doc


def _sweep_toml(doc) -> str:
    axes = doc.pop("axes")
    text = to_toml(doc)
    for name, table in axes.items():
        text += f'[axes."{name}"]\n' + "".join(f"{k} = {json.dumps(v) if isinstance(v, str) else _tv(v)}\n"
                                               for k, v in table.items())
    return text


def _tv(v):
    return to_toml({"x": v}).split(" = ", 1)[1].strip()


def _case(root):
    tmp = root / "case"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    (tmp / "base.toml").write_text(BASE)
    return tmp


def _overwrite(data: bytearray, where: float, blob: bytes) -> None:
    """``blob`` over ``data`` at the relative position ``where`` (cut at the end)."""
    start = int(where * (len(data) - 1))
    data[start:start + len(blob)] = blob[:len(data) - start]


def _run(capsys, args) -> int:
    """``xcheck args`` here: its exit code, once it is known to be 0, 1 or 2 with no traceback."""
    capsys.readouterr()
    code = main(args)
    _no_traceback(code, capsys.readouterr(), args)
    return code


def _no_traceback(code, out, args):
    if os.environ.get("XCHECK_FUZZ_LOG"):  # what the examples came to, for a long run by hand
        with open(os.environ["XCHECK_FUZZ_LOG"], "a") as f:
            f.write(f"{args[0]} {code} {(out.err.strip().splitlines() or [''])[-1][:150]}\n")
    assert code in (0, 1, 2, 4), f"exit {code} for {args}\n{out.err}"
    assert "Traceback" not in out.err and "Traceback" not in out.out, out.err
    if code == 2:
        assert out.err.startswith(("xcheck: error: ", "usage: xcheck")), out.err


@pytest.fixture(scope="module")
def playground(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz-newer")


@_settings(30)
@given(doc=sweep_specs())
def test_sweep_specs(playground, capsys, doc):
    """A spec is read without allocating beyond its limit (10 MB for 1000 cells), then run (at most 6 cells)."""
    tmp = _case(playground)
    spec = tmp / "spec.toml"
    spec.write_text(_sweep_toml(doc))
    tracemalloc.start()
    try:
        S.load_sweep(spec, max_cells=1000)
    except S.SweepError:
        pass
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 50e6, peak
    args = ["sweep", str(spec), "--out", str(tmp / "out"), "--jobs", "1", "--max-cells", "6"]
    _run(capsys, args)


DETERMINATION_KEYS = ["method", "dt", "seed", "sun_direction", "methods", "approach_angles_deg", "approach_noise",
                      "colour"]


DETERMINATION_VALUES = {
    "method": st.sampled_from(["mujoco-rk4", "lie-rkmk4", "warp"]),
    "dt": st.one_of(st.sampled_from([0.05, 0.1]), special),
    "seed": st.one_of(st.integers(-3, 2**70), special),
    "sun_direction": vectors,
    "methods": st.lists(st.sampled_from(["triad", "q-method", "quest", "svd", "davenport"]), max_size=3),
    "approach_angles_deg": st.lists(st.one_of(special, st.floats(1e-15, 120)), max_size=3),
    "approach_noise": st.sampled_from(["fine sensors", "loud"]),
}


@st.composite
def determination_tables(draw):
    keys = draw(st.lists(st.sampled_from(DETERMINATION_KEYS), max_size=3, unique=True))
    table = {key: draw(DETERMINATION_VALUES.get(key, anything)) for key in keys}
    noise = draw(st.lists(st.fixed_dictionaries({"name": st.sampled_from(["a", "b", "a"]),
                                                 "magnetometer_nT": st.one_of(special, st.floats(0, 1e5)),
                                                 "sun_deg": st.one_of(special, st.floats(0, 20))}), max_size=2))
    return table, noise


@_settings(25)
@given(spec=determination_tables(), field=st.sampled_from(["orbit-dipole", "uniform"]))
def test_determination_tables(playground, capsys, spec, field):
    table, noise = spec
    tmp = _case(playground)
    torque = '[torque]\nkind = "magnetic"\nfield = "uniform"\nH_world = [20.0, -5.0, 10.0]\n' if field == "uniform" \
        else '[torque]\nkind = "magnetic"\nfield = "orbit-dipole"\n'
    text = BASE.split("[torque]")[0] + torque + '[study]\nreference = "dop853"\n'
    text += "[determination]\n" + "".join(f"{k} = {_tv(v)}\n" for k, v in table.items())
    for level in noise:
        text += "[[determination.noise]]\n" + "".join(f"{k} = {_tv(v)}\n" for k, v in level.items())
    path = tmp / "s.toml"
    path.write_text(text)
    args = ["determine", str(path), "--json", str(tmp / "d.json")]
    code = _run(capsys, args)
    if code in (0, 1, 4):  # a study that ran wrote numbers, never NaN (allow_nan=False would have refused it)
        json.loads((tmp / "d.json").read_text())


@pytest.fixture(scope="module")
def history(playground, request):
    """A real history with one run of the small scenario (recorded by a nightly)."""
    folder = playground / "history-source"
    folder.mkdir(exist_ok=True)
    (folder / "base.toml").write_text(BASE)
    path = folder / "h.sqlite"
    assert main(["nightly", "--quick", "--workers", "1", "--speed-drop", "1", str(folder / "base.toml"), "--out",
                 str(folder / "out"), "--history", str(path)]) in (0, 1, 4)
    return path


@_settings(15)
@given(damage=st.lists(st.tuples(st.floats(0, 1), st.integers(1, 4096), st.sampled_from([b"\x00", b"\xff", b"x"])),
                       min_size=1, max_size=3))
def test_damaged_histories(playground, capsys, history, damage):
    """Bytes overwritten at random places: refused untouched (exit 2), or used, and then the earlier run is still
    in it."""
    tmp = _case(playground)
    path = tmp / "h.sqlite"
    shutil.copy(history, path)
    data = bytearray(path.read_bytes())
    for where, size, byte in damage:
        _overwrite(data, where, byte * size)
    path.write_bytes(bytes(data))
    before = path.read_bytes()
    args = ["nightly", "--quick", "--workers", "1", "--speed-drop", "1", str(tmp / "base.toml"), "--out",
            str(tmp / "out"), "--history", str(path)]
    code = _run(capsys, args)
    if code == 2:
        assert path.read_bytes() == before
    else:
        con = sqlite3.connect(path)
        assert con.execute("SELECT COUNT(*) FROM runs").fetchone()[0] == 2
        con.close()


SMALL_SWEEP = 'base = "base.toml"\nmethods = ["lie-rkmk4"]\n[axes.rate_scale]\nvalues = [0.5, 1.0, 1.5, 2.0]\n'


@pytest.fixture(scope="module")
def interrupted_log(playground):
    """The log of a sweep of four cells interrupted after its first chunk."""
    from xcheck.sweep import run as R

    folder = playground / "log-source"
    folder.mkdir(exist_ok=True)
    (folder / "base.toml").write_text(BASE)
    (folder / "small.toml").write_text(SMALL_SWEEP)

    def interrupt(done, total, label):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        R.run_sweep(S.load_sweep(folder / "small.toml"), folder / "out", jobs=1, progress=interrupt,
                    say=lambda s: None)
    return (folder / "out" / "small" / R.PARTIAL_LOG).read_bytes()


@_settings(20)
@given(cut=st.floats(0, 1), flips=st.lists(st.tuples(st.floats(0, 1), st.one_of(
           st.binary(min_size=1, max_size=8), st.text("0123456789.,:{}[]\" e-", min_size=1, max_size=8).map(str.encode))),
           max_size=2),
       extra=st.lists(st.one_of(st.sampled_from(['{}', '42', '[1]', '{"id": "x"}', 'null', '"s"']),
                               st.text(max_size=20)), max_size=2))
def test_resume_logs(playground, capsys, interrupted_log, cut, flips, extra):
    """A --resume log cut short, with bytes changed, or with foreign lines: refused untouched (exit 2), or resumed,
    and then every cell of the sweep is in its table."""
    import csv

    from xcheck.sweep import run as R

    tmp = _case(playground)
    (tmp / "small.toml").write_text(SMALL_SWEEP)
    log = tmp / "out" / "small" / R.PARTIAL_LOG
    log.parent.mkdir(parents=True)
    data = bytearray(interrupted_log[:max(1, int(cut * len(interrupted_log)))] if cut < 0.95 else interrupted_log)
    for where, blob in flips:
        _overwrite(data, where, blob)
    text = bytes(data) + "".join(line + "\n" for line in extra).encode("utf-8", "surrogatepass")
    log.write_bytes(text)
    args = ["sweep", str(tmp / "small.toml"), "--out", str(tmp / "out"), "--jobs", "1", "--resume"]
    code = _run(capsys, args)
    if code == 2:
        assert log.read_bytes() == text
    else:
        with open(tmp / "out" / "small" / "latest" / "results.csv", newline="") as f:
            cells = {r["cell"] for r in csv.DictReader(f)}
        assert len(cells) == 4
