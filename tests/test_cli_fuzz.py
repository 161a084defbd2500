"""The command line under generated abuse (issue 8, "Keeping it true"): scenario files with random keys,
types, encodings and values (NaN, inf, huge, tiny), random arguments and output paths. Whatever comes in,
``xcheck`` answers with exit code 0, 1 or 2 and a message, never a traceback (exit 3 is a bug: one line
asking to report it), and never leaves a hidden temporary file or folder behind.

Derandomized (the same examples on every run) and bounded (small durations and coarse steps, so that the
inputs that do run stay fast). Commands added later (nightly, sweep, determine, the pytest plugin's
collection) join the ``command`` strategy."""

import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xcheck.cli import main
from xcheck.paths import BUNDLED_MODELS
from xcheck.runners import RUNNERS

GYRO = str(BUNDLED_MODELS / "gyroscope.xml")
RAX1 = str(BUNDLED_MODELS / "rax1.xml")
TABLE = str(BUNDLED_MODELS / "rax1_field_body.csv")
#: The methods a generated run may use (fast ones, ours and MuJoCo's), and a few bad names.
METHODS = ["lie-rkmk4", "formulation-2", "euler-rk4", "scipy-rk45", "mujoco-rk4", "mujoco-euler"]

special_floats = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, 0.0, -0.0, 1e-12, 1e12,
                                  1e300, -1.0])
floats = st.one_of(special_floats, st.floats(-20, 20, allow_nan=False))
positive = st.one_of(special_floats, st.floats(1e-3, 2.0))
scalars = st.one_of(floats, st.integers(-5, 10**30), st.booleans(), st.text(max_size=8))
values = st.one_of(scalars, st.lists(scalars, max_size=5), st.lists(floats, min_size=3, max_size=4),
                   st.dictionaries(st.text(max_size=5), scalars, max_size=2))

TOP = ["name", "description", "model", "duration", "initial", "torque", "study", "checks"]
TABLE_KEYS = {
    "initial": ["quaternion", "angular_velocity", "angular_velocity_deg", "euler_sequence", "euler_angles_deg",
                "euler_rates"],
    "torque": ["kind", "torque", "field", "dipole", "table", "altitude_km", "inclination_deg", "H_world", "epoch"],
    "study": ["steps", "quick_steps", "methods", "reference", "reference_method", "reference_dt"],
    "checks": ["order_tolerance", "order_excess", "final_error", "invariant_tolerance", "agreement",
               "expected_to_fail"],
}
GOOD_VALUES = {
    ("torque", "kind"): st.sampled_from(["constant", "magnetic", "gravity"]),
    ("torque", "field"): st.sampled_from(["uniform", "body-table", "orbit-dipole", "world-table", "nope"]),
    ("torque", "table"): st.sampled_from([TABLE, "missing.csv", GYRO]),
    ("study", "reference"): st.sampled_from(["exact", "dop853", "fine", "best"]),
    ("study", "methods"): st.lists(st.sampled_from(METHODS + ["rk5"]), max_size=3),
    ("study", "steps"): st.lists(positive, min_size=0, max_size=3),
    ("study", "reference_method"): st.sampled_from(METHODS + ["rk5"]),
    ("initial", "euler_sequence"): st.sampled_from(["323", "313", "321", "111", "zyz"]),
    ("checks", "expected_to_fail"): st.lists(st.sampled_from(METHODS + ["nope"]), max_size=2),
    (None, "model"): st.sampled_from([GYRO, RAX1, TABLE, "missing.xml", "/"]),
    (None, "name"): st.sampled_from(["ok", "../../ESCAPED", "a/b", "", "x" * 120, "name.with.dots", "é"]),
    (None, "duration"): positive,
    ("initial", "quaternion"): st.lists(floats, min_size=3, max_size=5),
    ("initial", "angular_velocity"): st.lists(floats, min_size=2, max_size=4),
    ("initial", "angular_velocity_deg"): st.lists(floats, min_size=3, max_size=3),
    ("initial", "euler_angles_deg"): st.lists(floats, min_size=3, max_size=3),
    ("initial", "euler_rates"): st.lists(floats, min_size=3, max_size=3),
    ("torque", "torque"): st.lists(floats, min_size=3, max_size=3),
    ("torque", "dipole"): st.lists(floats, min_size=3, max_size=3),
    ("torque", "H_world"): st.lists(floats, min_size=3, max_size=3),
    ("study", "reference_dt"): positive,
    ("checks", "final_error"): positive,
}


def base():
    return {"name": "fuzz", "model": GYRO, "duration": 0.5,
            "initial": {"quaternion": [1.0, 0.0, 0.0, 0.0], "angular_velocity": [0.1, 0.2, 0.3]},
            "study": {"steps": [0.25, 0.125], "quick_steps": [0.25, 0.125], "methods": ["lie-rkmk4", "mujoco-rk4"]}}


@st.composite
def scenarios(draw):
    doc = base()
    for _ in range(draw(st.sampled_from([0, 0, 0, 1, 1, 2, 4]))):
        section = draw(st.sampled_from([None, "initial", "torque", "study", "checks", "new"]))
        if section is None:
            key = draw(st.one_of(st.sampled_from(TOP), st.sampled_from(TOP), st.text(min_size=1, max_size=6)))
            doc[key] = draw(GOOD_VALUES.get((None, key), values))
        else:
            name = section if section != "new" else draw(st.text(min_size=1, max_size=6))
            table = doc.setdefault(name, {})
            if not isinstance(table, dict):
                continue
            known = st.sampled_from(TABLE_KEYS.get(name, ["x"]))
            key = draw(st.one_of(known, known, known, st.text(min_size=1, max_size=6)))
            if draw(st.booleans()) and key in table:
                del table[key]
            else:
                table[key] = draw(GOOD_VALUES.get((name, key), values))
    return doc


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{_toml_string(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"


def _toml_string(v: str) -> str:
    """A TOML basic string: JSON's escapes for quotes, backslashes and control characters, the rest as is (a
    lone surrogate then fails to encode, and the file is written with it: not UTF-8, exit 2)."""
    return json.dumps(v, ensure_ascii=False)


def to_toml(doc) -> str:
    lines, tables = [], []
    for k, v in doc.items():
        (tables if isinstance(v, dict) else lines).append((k, v))
    out = [f"{_toml_string(k)} = {_toml_value(v)}" for k, v in lines]
    for k, table in tables:
        out.append(f"[{_toml_string(k)}]")
        out += [f"{_toml_string(kk)} = {_toml_value(vv)}" for kk, vv in table.items()]
    return "\n".join(out) + "\n"


encodings = st.sampled_from(["utf-8"] * 6 + ["utf-16", "latin-1", "garbage"])
BAD_PATHS = ["afile/x", "adir", "", "/proc/xcheck/x", "é ü", "x.txt"]


def out_file(suffix):
    """Mostly good file paths with the right ending (some in new folders), sometimes a bad one."""
    good = st.sampled_from([f"r{suffix}", f"sub/dir/r{suffix}", f"é ü{suffix}"])
    return st.one_of(good, good, good, st.sampled_from(BAD_PATHS + [f"afile/r{suffix}", f"adir{suffix}/"]))


out_dirs = st.one_of(st.sampled_from(["out", "new/out", "adir"]), st.sampled_from(BAD_PATHS))
step_lists = st.one_of(st.sampled_from(["0.25,0.125", "0.125,0.0625,0.03125", "0.5"]),
                       st.lists(st.sampled_from(["0.25", "0.125", "1e-12", "-1", "nan", "x", "5", ""]), max_size=3)
                       .map(",".join))


@st.composite
def commands(draw):
    kind = draw(st.sampled_from(["converge", "converge", "run", "run", "report"]))
    if kind == "converge":
        argv = ["converge", "{scenario}", "--workers", "1"]
        if draw(st.booleans()):
            argv += ["--methods", ",".join(draw(st.lists(st.sampled_from(METHODS * 3 + ["rk5", ""]), min_size=1,
                                                         max_size=3, unique=True)))]
        if draw(st.booleans()):
            argv += ["--steps", draw(step_lists)]
        if draw(st.booleans()):
            argv += ["--json", "{tmp}/" + draw(out_file(".json"))]
        if draw(st.booleans()):
            argv += ["--out", "{tmp}/" + draw(out_dirs)]
        if draw(st.booleans()):
            argv.append("--quick")
    elif kind == "run":
        argv = ["run", "{scenario}", "--method", draw(st.sampled_from(METHODS * 3 + ["rk5"])),
                "--dt", draw(st.sampled_from(["0.125"] * 4 + ["0.5", "0", "-1", "1e-13", "inf", "nan", "7"]))]
        if draw(st.booleans()):
            argv += ["--csv", "{tmp}/" + draw(out_file(".csv"))]
        if draw(st.booleans()):
            argv += ["--plot", "{tmp}/" + draw(out_file(draw(st.sampled_from([".png", ".svg", ".pdf"]))))]
    else:
        argv = ["report", "{scenario}", "--quick", "--workers", "1", "--out", "{tmp}/" + draw(out_dirs)]
    return argv


@pytest.fixture(scope="module")
def playground(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


@settings(max_examples=300, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(doc=scenarios(), encoding=encodings, argv=commands())
def test_cli_never_shows_a_traceback(playground, capsys, doc, encoding, argv):
    import shutil

    tmp = playground / "case"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    (tmp / "afile").write_text("x")
    (tmp / "adir").mkdir()
    text = to_toml(doc)
    path = tmp / "s.toml"
    if encoding == "garbage":
        path.write_bytes(text.encode()[: len(text) // 2] + b"\xff\xfe\x00\x81" + text.encode()[len(text) // 2:])
    else:
        try:
            path.write_bytes(text.encode(encoding))
        except UnicodeEncodeError:
            path.write_bytes(text.encode("utf-8", "surrogatepass"))
    args = [a.format(scenario=path, tmp=tmp) for a in argv]
    capsys.readouterr()  # nothing from an earlier example
    code = main(args)
    out = capsys.readouterr()
    assert code in (0, 1, 2, 4), f"exit {code} for {args}\n{text}\n{out.err}"
    assert "Traceback" not in out.err and "Traceback" not in out.out, out.err
    if code == 2:  # one message: ours, or argparse's usage and error
        assert out.err.startswith(("xcheck: error: ", "usage: xcheck")) and len(out.err.splitlines()) <= 5, out.err
    leftovers = [p for p in tmp.rglob(".*") if p.name.startswith((".incomplete-", ".latest-")) or p.suffix == ".tmp"]
    assert not leftovers, leftovers
    assert not list(playground.glob("*ESCAPED*")) and not list(Path(playground.parent).glob("*ESCAPED*"))


def test_fuzz_methods_are_registered():
    """The strategy's method names must be real (else the fuzz test would only ever see refusals)."""
    assert set(METHODS) <= set(RUNNERS)
