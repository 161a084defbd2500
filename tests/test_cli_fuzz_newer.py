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
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from test_cli_fuzz import to_toml  # noqa: E402  (the same TOML writer)

from xcheck.cli import main
from xcheck.commands.sweeps import run_sweep
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
        run_sweep(S.load_sweep(folder / "small.toml"), folder / "out", jobs=1, progress=interrupt,
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


# ------------------------------------------------------------------------------------------------------
# issue 37: MJCF in (keyframes, pulses, actuators, flags), `init`, [[torque]] lists, the torques axis
# ------------------------------------------------------------------------------------------------------
mjcf_numbers = st.one_of(special, st.floats(-3, 3, allow_nan=False), st.sampled_from([0.004, 0.2, 1.0, 2.0, 9.81]))


def _nums(draw, n, good):
    """``n`` numbers as MJCF writes them: mostly ``good`` (the model's own), sometimes any, sometimes a wrong count."""
    if draw(st.integers(0, 9)):
        return " ".join(repr(float(v)) for v in good)
    values = draw(st.lists(mjcf_numbers, min_size=max(0, n - 1), max_size=n + 1))
    return " ".join("nan" if math.isnan(v) else repr(float(v)) for v in values)


@st.composite
def wheel_models(draw):
    """tumbler_wheels.xml with its numbers, keyframe, pulse, motor and flags drawn."""
    gear = _nums(draw, 1, [1.0])
    motor = draw(st.sampled_from([
        f'<motor name="spin_x" joint="wheel_x" gear="{gear}"/>',
        f'<motor name="spin_x" joint="wheel_x" gear="{gear}" forcerange="-0.1 0.1" forcelimited="true"/>',
        '<motor name="spin_x" joint="wheel_x"/>', '<motor name="spin_x" joint="wheel_x"/>', "",
        '<motor name="spin_y" joint="wheel_y"/>']))
    flags = draw(st.sampled_from(['<flag contact="disable"/>', '<flag contact="disable" actuation="disable"/>',
                                  '<flag contact="disable" gravity="disable"/>']))
    pulse = draw(st.sampled_from(["spin_x", "spin_x", "spin_x", "spin_y", "nobody"]))
    key = ""
    if draw(st.booleans()):
        key = (f'<keyframe><key name="k" qpos="{_nums(draw, 9, [0, 0, 0, 1, 0, 0, 0, 0, 0])}" '
               f'qvel="{_nums(draw, 8, [0, 0, 0, 0.3, 1.0, 0.2, 0, 0])}"/></keyframe>')
    frc = ' actuatorfrcrange="-0.05 0.05"' if draw(st.integers(0, 4)) == 0 else ""
    return f'''<mujoco model="fuzz_wheels">
  <compiler angle="radian" inertiafromgeom="false"/>
  <option gravity="{_nums(draw, 3, [0, 0, 0])}" timestep="0.01" integrator="RK4">{flags}</option>
  <custom><numeric name="xcheck_pulse:{pulse}" data="{_nums(draw, 3, [0.2, 0, 1])}"/></custom>
  <worldbody>
    <body name="bus">
      <freejoint name="free"/>
      <inertial pos="0 0 0" mass="{_nums(draw, 1, [2.0])}" diaginertia="{_nums(draw, 3, [1, 2, 3])}"/>
      <body name="wheel_x" pos="0.2 0 0">
        <joint name="wheel_x" type="hinge" axis="{_nums(draw, 3, [1, 0, 0])}"{frc}/>
        <inertial pos="0 0 0" mass="0.3" diaginertia="0.004 0.0025 0.0025"/>
      </body>
      <body name="wheel_y" pos="0 0.2 0">
        <joint name="wheel_y" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0" mass="0.3" diaginertia="0.0025 0.004 0.0025"/>
      </body>
    </body>
  </worldbody>
  <actuator>{motor}</actuator>{key}
</mujoco>
'''


@st.composite
def top_models(draw):
    """heavy_top.xml with its gravity, pivot, masses, keyframe and gravcomp drawn."""
    gravcomp = ' gravcomp="1"' if draw(st.integers(0, 4)) == 0 else ""
    key = ""
    if draw(st.booleans()):
        key = (f'<keyframe><key name="k" qpos="{_nums(draw, 4, [0.9962, 0.0872, 0, 0])}" '
               f'qvel="{_nums(draw, 3, [0, 0, 50.0])}"/></keyframe>')
    return f'''<mujoco model="fuzz_top">
  <compiler angle="radian" inertiafromgeom="false"/>
  <option gravity="{_nums(draw, 3, [0, 0, -9.81])}" timestep="0.004" integrator="RK4"><flag contact="disable"/></option>
  <worldbody>
    <body name="top" pos="0 0 0.5"{gravcomp}>
      <joint name="pivot" type="ball" pos="{_nums(draw, 3, [0, 0, 0])}"/>
      <inertial pos="{_nums(draw, 3, [0, 0, 0.01])}" mass="{_nums(draw, 1, [2.0])}" diaginertia="0.0028125 0.0028125 0.005625"/>
    </body>
  </worldbody>{key}
</mujoco>
'''


def _model_case(playground, text):
    tmp = _case(playground)
    model = tmp / "m.xml"
    model.write_text(text)
    return tmp, model


def _init_then_run(capsys, tmp, model):
    """`init` on the model: refused (exit 2, the model untouched), or the scenario it wrote is read back and runs
    in MuJoCo and in ours at the model's own keyframe, a run ending (exit 0) or failing as a run (1), never refused."""
    before = model.read_bytes()
    keyed = f"{model}#k" if b'<key name="k"' in before else str(model)
    code = _run(capsys, ["init", keyed, "--out", str(tmp / "s.toml")])
    assert model.read_bytes() == before
    if code == 2:
        assert not (tmp / "s.toml").exists()
        return
    assert code == 0
    for method in ("mujoco-rk4", "lie-rkmk4"):
        args = ["run", str(tmp / "s.toml"), "--method", method, "--dt", "0.05"]
        assert _run(capsys, args) in (0, 1), args


@_settings(12)
@given(text=wheel_models())
def test_mjcf_gyrostats_with_keyframes_pulses_and_motors(playground, capsys, text):
    tmp, model = _model_case(playground, text)
    _init_then_run(capsys, tmp, model)


@_settings(12)
@given(text=top_models())
def test_mjcf_heavy_tops_with_keyframes_and_gravity(playground, capsys, text):
    tmp, model = _model_case(playground, text)
    _init_then_run(capsys, tmp, model)


TORQUE_TERMS = {
    "magnetic": st.one_of(st.fixed_dictionaries({"field": st.sampled_from(["orbit-dipole", "warp"])},
                                                optional={"altitude_km": numbers}),
                          st.fixed_dictionaries({"field": st.just("uniform"),
                                                 "H_world": st.one_of(st.just([20.0, -5.0, 10.0]), vectors)})),
    "gravity-gradient": st.fixed_dictionaries({}, optional={"altitude_km": numbers, "inclination_deg": numbers}),
    "constant": st.fixed_dictionaries({"torque": vectors}),
    "solar-pressure": st.fixed_dictionaries({"centre_of_pressure": st.one_of(st.just([0.01, 0.0, 0.02]), vectors),
                                             "area": st.one_of(st.just(0.01), numbers)},
                                            optional={"reflectivity": numbers}),
    "aerodynamic": st.fixed_dictionaries({"centre_of_pressure": st.one_of(st.just([0.01, 0.0, 0.02]), vectors),
                                          "area": st.one_of(st.just(0.01), numbers)},
                                         optional={"density": numbers, "drag_coefficient": numbers}),
    "junk": st.dictionaries(st.text(max_size=5), anything, max_size=2),
}


@st.composite
def torque_lists(draw):
    terms = []
    for kind in draw(st.lists(st.sampled_from(sorted(TORQUE_TERMS)), min_size=0, max_size=3)):
        table = dict(draw(TORQUE_TERMS[kind]))
        if kind != "junk" or draw(st.booleans()):
            table["kind"] = kind
        terms.append(table)
    return terms


@_settings(20)
@given(terms=torque_lists())
def test_torque_lists(playground, capsys, terms):
    """A [[torque]] list of drawn terms on RAX-1: refused naming `[torque[k]]`, or a study that runs."""
    tmp = _case(playground)
    text = BASE.split("[torque]")[0] + "".join("[[torque]]\n" + "".join(f"{json.dumps(k)} = {_tv(v)}\n"
                                                                         for k, v in t.items())
                                               for t in terms) + BASE[BASE.index("[study]"):]
    path = tmp / "s.toml"
    path.write_text(text)
    code = _run(capsys, ["converge", str(path), "--quick", "--workers", "1"])
    err = capsys.readouterr().err  # (read by _run: this is what came after, nothing)
    assert code in (0, 1, 2, 4) and not err


@_settings(12)
@given(sets=st.one_of(st.lists(st.lists(st.sampled_from(["magnetic", "gravity-gradient"]), max_size=2, unique=True),
                               min_size=1, max_size=3),
                      st.lists(st.lists(st.sampled_from(["magnetic", "aerodynamic", "warp", ""]), max_size=3),
                               max_size=3), anything))
@example(sets=[["magnetic"], ["magnetic", "gravity-gradient"], []])  # the documentation's own
def test_the_torques_axis(playground, capsys, sets):
    """Issue 37, 1: the torques axis ran every cell, then crashed summarising them. Any value: refused when the spec
    is read, or a report with one row per cell."""
    tmp = _case(playground)
    base = BASE.split("[torque]")[0] + ('[[torque]]\nkind = "magnetic"\nfield = "orbit-dipole"\n[[torque]]\n'
                                        'kind = "gravity-gradient"\n') + BASE[BASE.index("[study]"):]
    (tmp / "base.toml").write_text(base)
    spec = tmp / "spec.toml"
    spec.write_text('base = "base.toml"\nmethods = ["lie-rkmk4"]\n[axes.torques]\n' f"values = {_tv(sets)}\n")
    code = _run(capsys, ["sweep", str(spec), "--out", str(tmp / "out"), "--jobs", "1", "--max-cells", "4"])
    if code != 2:
        import csv

        with open(tmp / "out" / "spec" / "latest" / "results.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        assert rows and all(r["torques"] for r in rows if r["torques"] != "none")
