"""Issue 37: the newest surfaces under abuse — MJCF settings MuJoCo obeys (modelled or refused), inputs that are not
numbers a body can have, files that are not files, torques that cannot be evaluated. Each case is refused before
any work with exit 2 and a message naming the file and the element or key; the refused file is left byte-identical.
The stated truth of the modelled cases is MuJoCo itself: where xcheck models what MuJoCo does, MuJoCo's RK4 agrees
with xcheck's reference to its own truncation error."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from xcheck.cli import main
from xcheck.paths import BUNDLED_MODELS

MODELS = BUNDLED_MODELS


def _variant(tmp_path, model: str, old: str, new: str, name: str = "m.xml") -> Path:
    text = (MODELS / model).read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path


def _refused(tmp_path, capsys, arg, *needles):
    before = Path(str(arg).partition("#")[0]).read_bytes() if Path(str(arg)).is_file() else None
    assert main(["report", str(arg), "--quick", "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err, err
    for needle in needles:
        assert needle in err, (needle, err)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    if before is not None:
        assert Path(str(arg)).read_bytes() == before


# (model, text in it, replacement, what the refusal names)
MJCF_CASES = {
    "gravcomp-on-a-top": ("heavy_top.xml", '<body name="top" pos="0 0 0.5">', '<body name="top" pos="0 0 0.5" gravcomp="1">',
                          ["body 'top' has gravcomp=\"1\""]),
    "clipped-by-actuatorfrcrange": ("tumbler_wheels.xml", '<joint name="wheel_x" type="hinge" axis="1 0 0"/>',
                                    '<joint name="wheel_x" type="hinge" axis="1 0 0" actuatorfrcrange="-0.01 0.01"/>',
                                    ["actuator 'spin_x'", "actuatorfrcrange [-0.01, 0.01]"]),
    "a-gear-of-1e-300": ("tumbler_wheels.xml", '<motor name="spin_x" joint="wheel_x"/>',
                         '<motor name="spin_x" joint="wheel_x" gear="1e-300"/>', ["actuator 'spin_x'", "control of 2e+299"]),
    "a-forcerange-in-force-not-torque": ("tumbler_wheels.xml", '<motor name="spin_x" joint="wheel_x"/>',
                                         '<motor name="spin_x" joint="wheel_x" gear="4" forcelimited="true" '
                                         'forcerange="-0.04 0.04"/>', ["needs 0.05 within its forcerange"]),
    "nan-gravity-on-a-top": ("heavy_top.xml", 'gravity="0 0 -9.81"', 'gravity="0 0 nan"', ["<option gravity>", "not finite"]),
    "gravity-of-1e300": ("heavy_top.xml", 'gravity="0 0 -9.81"', 'gravity="0 0 -1e300"', ["<option gravity=", "a thousand g"]),
    "nan-hinge-axis": ("gyrostat.xml", '<joint name="wheel" type="hinge" axis="0 0 1"/>',
                       '<joint name="wheel" type="hinge" axis="0 0 nan"/>', ["joint 'wheel': <joint axis>", "not finite"]),
    "nan-wheel-speed-in-the-keyframe": ("gyrostat.xml", 'qvel="0 0 0 0.3 -0.2 0.5 50"', 'qvel="0 0 0 0.3 -0.2 0.5 nan"',
                                        ["'spinning'", "nan rad/s"]),
    "keyframe-rate-of-1e300": ("gyrostat.xml", 'qvel="0 0 0 0.3 -0.2 0.5 50"', 'qvel="0 0 0 1e300 -0.2 0.5 50"',
                               ["keyframe 'spinning'", "|omega| = 1e+300 rad/s"]),
    "keyframe-wheel-speed-of-1e300": ("gyrostat.xml", 'qvel="0 0 0 0.3 -0.2 0.5 50"', 'qvel="0 0 0 0.3 -0.2 0.5 1e300"',
                                      ["'spinning'", "1e+300 rad/s"]),
}


@pytest.mark.parametrize("case", list(MJCF_CASES))
def test_mjcf_settings_and_numbers_xcheck_cannot_model_are_refused(tmp_path, capsys, case):
    model, old, new, needles = MJCF_CASES[case]
    path = _variant(tmp_path, model, old, new)
    _refused(tmp_path, capsys, path, "m.xml", *needles)


def test_disabled_actuation_is_modelled_as_motors_that_exert_nothing(tmp_path):
    """<flag actuation="disable"/>: MuJoCo applies no motor force, so the pulse is left out of xcheck's model too.
    Truth: MuJoCo's RK4 at 1/256 s against xcheck's reference of the same model agrees to 1e-8 rad (it was 0.126
    rad apart when xcheck applied the pulse MuJoCo did not)."""
    from xcheck.models import load_body
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study

    path = _variant(tmp_path, "tumbler_wheels.xml", '<flag contact="disable"/>',
                    '<flag contact="disable" actuation="disable"/>')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        body = load_body(path)
    assert all(w.pulse is None for w in body.wheels)
    assert any("actuation disabled" in str(w.message) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = run_study(resolve_scenario(str(path)), methods=["mujoco-rk4", "lie-rkmk4"], steps=[1 / 256], workers=1,
                       timing=False)
    for m in ("mujoco-rk4", "lie-rkmk4"):
        assert st.methods[m].runs[0].attitude_error < 1e-8, (m, st.methods[m].runs[0].attitude_error)


@pytest.mark.parametrize("kind, table, needles", [
    ("two constant terms that overflow their sum",
     '[[torque]]\nkind = "constant"\ntorque = [1.5e308, 0, 0]\n[[torque]]\nkind = "constant"\ntorque = [1.5e308, 0, 0]\n',
     ["[torque]", "[inf, 0.0, 0.0] N m at t = 0 s", "not finite"]),
    ("a drag of density 1e300", '[torque]\nkind = "aerodynamic"\ncentre_of_pressure = [0.01, 0, 0]\narea = 0.03\n'
                                'density = 1e300\n', ["density x drag_coefficient x area", "overflows"]),
    ("a solar pressure of 1e300", '[torque]\nkind = "solar-pressure"\ncentre_of_pressure = [0.01, 0, 0]\narea = 0.03\n'
                                  'pressure = 1e300\n', ["pressure x reflectivity x area", "overflows"]),
    ("an altitude of 1e300", '[torque]\nkind = "gravity-gradient"\naltitude_km = 1e300\n', ["altitude_km", "Hill sphere"]),
    ("a rate of 1e300", "", ["[initial] angular_velocity", "1e+300 rad/s"]),
])
def test_scenarios_that_cannot_be_evaluated_are_refused_before_any_work(tmp_path, capsys, kind, table, needles):
    """A torque of inf hung scipy's DOP853 at t = 0 for ever (its budget is checked between steps); an altitude or a
    rate of 1e300 overflowed deep inside (exit 3)."""
    rate = "[1e300, 0.2, 0.3]" if "rate" in kind else "[0.1, 0.2, 0.3]"
    path = tmp_path / "s.toml"
    path.write_text(f'name = "s"\nmodel = "{MODELS / "rax1.xml"}"\nduration = 1.0\n[initial]\nquaternion = [1, 0, 0, 0]\n'
                    f'angular_velocity = {rate}\n{table}[study]\nreference = "dop853"\n')
    _refused(tmp_path, capsys, path, "s.toml", *needles)


def test_a_non_finite_derivative_stops_the_reference_at_once():
    """The reference's own guard (what stops scipy's DOP853 spinning inside one step): ReferenceFailure naming t."""
    from xcheck.reference import ReferenceFailure, dop853_solution

    with pytest.raises(ReferenceFailure, match="torque is not finite at t = 0"):
        dop853_solution([1.0, 2.0, 3.0], [1, 0, 0, 0], [0.1, 0.2, 0.3], 1.0,
                        torque=lambda t, q, w: np.array([np.inf, 0.0, 0.0]))


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
@pytest.mark.parametrize("what", ["fifo.toml", "fifo.xml", "/dev/zero", "folder", "loop.xml", "big.toml", "big.xml"])
def test_files_that_are_not_inputs_are_named_before_they_are_read(tmp_path, capsys, what):
    """A FIFO blocked the reader for ever, /dev/zero or a 3 GB file was read whole into memory, a symlink loop crashed
    (exit 3), a folder or a FIFO was "no such MJCF file". Now each is named for what it is, in well under a second."""
    if what.startswith("fifo"):
        arg = tmp_path / what
        os.mkfifo(arg)
        needle = "a FIFO, not"
    elif what == "/dev/zero":
        arg, needle = what, "a device, not a scenario file"
    elif what == "folder":
        arg, needle = tmp_path, "a folder, not a scenario file"
    elif what == "loop.xml":
        arg = tmp_path / what
        (tmp_path / "other.xml").symlink_to(arg)
        arg.symlink_to(tmp_path / "other.xml")
        needle = "a loop of symbolic links, not an MJCF file"
    else:
        arg = tmp_path / what
        with open(arg, "wb") as f:
            f.truncate(65 * 2**20)  # sparse: no disk used
        needle = "bytes, more than the 64 MB"
    assert main(["report", str(arg), "--quick", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert needle in err and str(arg) in err, err


def test_a_model_path_with_a_hash_is_the_file_itself(tmp_path):
    """`hash#dir/m.xml` was split at the '#' into a file 'hash' and a keyframe, and read as TOML."""
    from xcheck.scenario import resolve_scenario, split_model_arg

    folder = tmp_path / "hash#dir"
    folder.mkdir()
    (folder / "m.xml").write_text((MODELS / "tumbler.xml").read_text())
    assert split_model_arg(f"{folder}/m.xml") == (folder / "m.xml", None)
    assert split_model_arg(f"{folder}/m.xml#spin") == (folder / "m.xml", "spin")
    sc = resolve_scenario(str(folder / "m.xml"))
    np.testing.assert_allclose(sc.omega0, [0.1, 0.5, 1.0])


def test_an_igrf_epoch_outside_the_coefficients_is_refused(tmp_path, capsys):
    """ppigrf extrapolated an epoch of 9999 and printed warnings on stdout; the refusal names the key and the span."""
    pytest.importorskip("ppigrf", reason="the IGRF field needs the optional extra xcheck[igrf]")
    path = tmp_path / "s.toml"
    path.write_text(f'name = "s"\nmodel = "{MODELS / "rax1.xml"}"\nduration = 1.0\n[initial]\nquaternion = [1, 0, 0, 0]\n'
                    'angular_velocity = [0.1, 0.2, 0.3]\n[torque]\nkind = "magnetic"\nfield = "igrf"\nepoch = '
                    '"9999-01-01"\n[study]\nreference = "dop853"\n')
    assert main(["report", str(path), "--quick", "--out", str(tmp_path / "out")]) == 2
    captured = capsys.readouterr()
    assert "epoch: '9999-01-01' is outside the IGRF coefficients' span, 1900-01-01 to" in captured.err
    assert captured.out == ""


def test_the_contact_scan_finds_exactly_the_pairs_that_can_touch():
    """The linear scan (OR-ed bits per rigid body) against the pairwise definition on 200 random models: a pair is
    found exactly when some two geoms of different rigid bodies have contype & conaffinity in common, and the pair
    it names is one of them. (The pairwise scan took 13 s on 10 000 geoms.)"""
    import mujoco

    from xcheck.models import _possible_contact

    rng = np.random.default_rng(37)
    for _ in range(200):
        bits = rng.integers(0, 4, size=(7, 2))
        g = [f'contype="{a}" conaffinity="{b}"' for a, b in bits]
        xml = (f'<mujoco><worldbody><geom name="w0" size="0.1" {g[0]}/><geom name="w1" size="0.1" {g[1]}/>'
               f'<body name="b"><freejoint/><geom name="b0" size="0.1" {g[2]}/><geom name="b1" size="0.1" {g[3]}/>'
               f'<body name="part"><geom name="p0" size="0.1" {g[4]}/></body></body>'
               f'<body name="static" pos="1 0 0"><geom name="s0" size="0.1" {g[5]}/><geom name="s1" size="0.1" {g[6]}/>'
               '</body></worldbody></mujoco>')
        model = mujoco.MjModel.from_xml_string(xml)
        weld = model.body_weldid[model.geom_bodyid]
        pairs = [(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i), mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, j))
                 for i in range(model.ngeom) for j in range(model.ngeom) if weld[i] != weld[j]
                 and (model.geom_contype[i] & model.geom_conaffinity[j] or model.geom_contype[j] & model.geom_conaffinity[i])]
        found = _possible_contact(model)
        assert (found is None) == (not pairs), (bits.tolist(), found, pairs)
        assert found is None or found in pairs


def test_workers_are_at_most_one_per_cpu(capsys):
    """--workers 1000 started a thousand interpreters (5.5 GB for 100; a 2 s job took 107 s): the pool is capped at
    the CPU count, and the command says so."""
    from xcheck.base.pool import make_pool

    pool = make_pool(1000)
    try:
        assert pool._max_workers == (os.cpu_count() or 1)
    finally:
        pool.shutdown()
    assert main(["report", "no-such-scenario", "--workers", "1000"]) == 2
    assert f"note: --workers 1000: {os.cpu_count() or 1} worker processes, one per CPU" in capsys.readouterr().err


@pytest.mark.parametrize("folder", ["emo\U0001F600ji", "new\nline", 'quote"d'])
def test_init_writes_a_file_that_reads_back_whatever_the_path(tmp_path, monkeypatch, capsys, folder):
    """Issue 37, 5: a path with an emoji was written as JSON's surrogate escapes (not TOML), exit 0, a file that could
    not be read back. Truth: the written scenario reads back with the model's own path and the model's numbers."""
    from xcheck.scenario import load_scenario

    monkeypatch.chdir(tmp_path)
    (tmp_path / folder).mkdir()
    (tmp_path / folder / "m.xml").write_text((MODELS / "tumbler.xml").read_text())
    assert main(["init", f"{folder}/m.xml", "--out", "s.toml"]) == 0
    sc = load_scenario(tmp_path / "s.toml")
    assert sc.model == (tmp_path / folder / "m.xml").resolve()
    np.testing.assert_allclose(sc.omega0, [0.1, 0.5, 1.0])


@pytest.mark.parametrize("old, new, needle", [
    ('qvel="0 0 0 0.3 -0.2 0.5 50"', 'qvel="0 0 0 nan -0.2 0.5 50"', "keyframe 'spinning': the free joint's qvel"),
    ('qvel="0 0 0 0.3 -0.2 0.5 50"', 'qvel="0 0 0 inf -0.2 0.5 50"', "keyframe 'spinning': the free joint's qvel"),
    ('qvel="0 0 0 0.3 -0.2 0.5 50"', 'qvel="0 0 0 0.3 -0.2 0.5 1e300"', "its speed in the first keyframe"),
])
def test_init_refuses_a_keyframe_no_body_can_start_from(tmp_path, capsys, old, new, needle):
    """Issue 37, 5: init wrote NaN, inf and 1e300 rates into a file that could not be read back (exit 0), and the
    report named `[initial] angular_velocity` for the MJCF keyframe's NaN. Now the MJCF's keyframe is named; nothing
    is written."""
    path = _variant(tmp_path, "gyrostat.xml", old, new)
    assert main(["init", str(path), "--out", str(tmp_path / "s.toml")]) == 2
    err = capsys.readouterr().err
    assert needle in err and "m.xml" in err and "[initial]" not in err, err
    assert not (tmp_path / "s.toml").exists()


def test_init_refuses_a_pulse_mujoco_would_zero(tmp_path, capsys):
    path = _variant(tmp_path, "tumbler_wheels.xml", 'data="0.2 0 1"', 'data="1e300 0 1"')
    assert main(["init", str(path), "--out", str(tmp_path / "s.toml")]) == 2
    assert "actuator 'spin_x': its pulse of 1e+300 N m" in capsys.readouterr().err
    assert not (tmp_path / "s.toml").exists()
