"""MJX, MuJoCo's JAX port, as an engine (issue 29). Truths: MuJoCo itself (the same model and algorithm in C and
float64: MJX's semi-implicit Euler in float64 must agree with MuJoCo's to round-off, motors' commands included), the
exact reference (orders, float32's floor), and the held input's first order against DOP853."""

import numpy as np
import pytest

from xcheck.engines import available

if not available("mjx"):
    pytest.skip("MJX is not installed (the extra mjx: pip install 'xcheck[mjx]', PyPI mujoco-mjx and jax): its "
                "tests skip", allow_module_level=True)

from xcheck.reference import exact_torque_free  # noqa: E402
from xcheck.rotations import attitude_error  # noqa: E402
from xcheck.scenario import resolve_scenario  # noqa: E402
from xcheck.study.context import run_context  # noqa: E402
from xcheck.versions import package_version  # noqa: E402


def _run(engine, scenario, integrator, dt, **kw):
    ctx = run_context(resolve_scenario(scenario))
    if engine == "mjx":
        from xcheck.engines.mjx import simulate
    else:
        from xcheck.engines.mujoco import simulate
    return ctx, simulate(ctx.model_path, integrator=integrator, q0=ctx.q0, omega0=ctx.omega0, dt=dt,
                         duration=ctx.duration, torque=ctx.applied, wheel_speeds=ctx.wheel_speeds, **kw)


@pytest.mark.parametrize("scenario", ["tumbler-three-wheels", "heavy-top"])
def test_mjx_euler_in_float64_is_mujocos_euler(scenario):
    """The same semi-implicit Euler step in JAX and in C: free body, gyrostat with a motor's pulse (MJX's command held
    from the step's start, as MuJoCo's one stage takes it), ball joint under gravity."""
    _, mine = _run("mjx", scenario, "euler", 1 / 256, x64=True)
    _, theirs = _run("mujoco", scenario, "euler", 1 / 256)
    assert mine.status == theirs.status == "ok"
    assert len(mine.t) == len(theirs.t)
    assert np.max(attitude_error(mine.q, theirs.q)) < 1e-9
    np.testing.assert_allclose(mine.omega, theirs.omega, atol=1e-8)
    assert mine.extras["precision"] == "float64"


def test_a_held_torque_leaves_mjx_first_order():
    """RAX-1 in its orbit field: the torque taken at each step's start and held (xfrc_applied through a host callback)
    leaves MJX's RK4 first order against DOP853 (the error halves with the step), as the study declares."""
    from xcheck.reference import dop853
    from xcheck.runners import RUNNERS

    sc = resolve_scenario("rax1-orbit-field")
    assert RUNNERS["mjx-rk4-x64"].order_for(sc.torque, sc.model)[0] == 1
    ctx = run_context(sc)
    from xcheck.engines.mjx import simulate

    errors = []
    for dt in (0.125, 0.0625):
        tr = simulate(ctx.model_path, integrator="rk4", q0=ctx.q0, omega0=ctx.omega0, dt=dt, duration=ctx.duration,
                      torque=ctx.applied, x64=True)
        q, _ = dop853(ctx.inertia, ctx.q0, ctx.omega0, np.array([0.0, tr.t[-1]]), torque=ctx.torque)
        errors.append(float(attitude_error(tr.q[-1], q[-1])))
    assert np.log2(errors[0] / errors[1]) == pytest.approx(1.0, abs=0.1), errors


def test_mjx_is_opt_in(monkeypatch):
    """Installed, MJX's methods join a study only where asked for ($XCHECK_WITH, --with, a method list)."""
    from xcheck.study import default_methods

    sc = resolve_scenario("tumbler-intermediate-axis")
    monkeypatch.delenv("XCHECK_WITH", raising=False)
    assert [m for m in default_methods(sc) if "mjx" in m] == []
    monkeypatch.setenv("XCHECK_WITH", "mjx")
    assert [m for m in default_methods(sc) if "mjx" in m] == ["mjx-rk4", "mjx-rk4-x64", "mjx-euler", "mjx-euler-x64",
                                                               "mjx-implicitfast", "mjx-implicitfast-x64"]


def test_with_mjx_asks_for_its_methods(tmp_path, monkeypatch, capsys):
    """``--with mjx`` sets $XCHECK_WITH for the command and its workers before any work (here the work stops at once,
    at a scenario that does not exist, naming it)."""
    import os

    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XCHECK_WITH", "")  # recorded, so that the command's setting is undone after the test
    code = main(["report", "--quick", "--with", "mjx", "--out", str(tmp_path / "r"), "no-such-scenario"])
    assert code == 2 and "no-such-scenario" in capsys.readouterr().err
    assert os.environ["XCHECK_WITH"] == "mjx"


@pytest.mark.parametrize("args, said", [(["report", "--quick", "--with", "basilisk"], "--with: 'basilisk' is not an opt-in"),
                                        (["bench", "--with", "warp"], "--with: 'warp' is not an opt-in engine"),
                                        (["mjx", "--methods", "mujoco-rk4"], "--methods: 'mujoco-rk4' is not MJX's")])
def test_bad_mjx_arguments_are_named(tmp_path, monkeypatch, capsys, args, said):
    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err, err


def test_xcheck_mjx_writes_its_table(tmp_path, monkeypatch, capsys):
    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "mjx.md"
    code = main(["mjx", "tumbler-intermediate-axis", "--methods", "mjx-rk4-x64", "--no-bench", "--out", str(out),
                 "--workers", "1"])
    said = capsys.readouterr()
    assert code == 0, said.err
    text = out.read_text()
    assert "Made by `xcheck mjx tumbler-intermediate-axis --methods mjx-rk4-x64 --out mjx.md`" in text
    assert "| tumbler-intermediate-axis | mjx-rk4-x64 | 4 | 2.00 |" in text
    assert "| tumbler-intermediate-axis | mujoco-rk4 | 4 | 4.0" in text
    assert "Failed to import warp" not in said.out


def test_mjx_rk4_is_second_order_and_float32_has_a_floor():
    """Against the exact solution on the tumbler: RK4 in float64 falls 4x a halving (order 2, as MuJoCo's before
    4.0.0: MJX 3.17 keeps that RK4); in float32 it stalls near 1e-5 rad, out of the step-size table's 1e-6. (Last in
    this file: float32 after float64, so that no test after it pays a recompilation for the switch.)"""
    ctx = run_context(resolve_scenario("tumbler-intermediate-axis"))
    errors = {}
    for x64, steps in ((True, (1 / 512, 1 / 1024)), (False, (1 / 1024,))):
        for dt in steps:
            _, tr = _run("mjx", "tumbler-intermediate-axis", "rk4", dt, x64=x64)
            q, _ = exact_torque_free(ctx.inertia, ctx.q0, ctx.omega0, tr.t[-1:])
            errors[x64, dt] = float(attitude_error(tr.q[-1], q[-1]))
    order = np.log2(errors[True, 1 / 512] / errors[True, 1 / 1024])
    expected = 4.0 if tuple(map(int, package_version("mujoco-mjx").split(".")[:2])) >= (4, 0) else 2.0
    assert order == pytest.approx(expected, abs=0.1), errors
    assert errors[True, 1 / 1024] < 1e-6 < errors[False, 1 / 1024] < 1e-4, errors
