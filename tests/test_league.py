"""The league table on the boxes benchmark (issue 29). Truths: the benchmark's own constants and columns
(``boxes.cc``: E0 = 5.001041625 and 368.5464125 J; ``angMomentum0`` 0.404166 and 3.41765; ``simTime``), the
definitions computed by hand on made-up runs, and the published figures themselves: MuJoCo's Euler takes ODE's
step, its implicit Bullet's, so their relative errors must agree to the published digits."""

import math

import numpy as np
import pytest

from xcheck.league import boxes as B
from xcheck.league.run import mujoco_rows, our_rows
from xcheck.league.table import checks, entries, markdown, slope


def test_the_box_and_its_initial_invariants_are_the_benchmarks():
    """Inertia m/12 (b^2 + c^2, ...) = (97, 82, 17)/120 kg m^2; E0 and |H0| as their constants and CSV columns."""
    np.testing.assert_allclose(B.INERTIA, np.array([97, 82, 17]) / 120, rtol=1e-15)
    # their constants were worked out with the moments rounded to six digits (0.808333...): 2e-8 apart at most
    assert B.CASES["simple"].energy0 == pytest.approx(5.001041625, rel=2e-8)
    assert B.CASES["complex"].energy0 == pytest.approx(368.5464125, rel=2e-8)
    assert B.CASES["simple"].energy0 == pytest.approx(4.9 + 97 / 120 / 8, rel=1e-15)
    for case, h0 in (("simple", 0.404166), ("complex", 3.41765)):
        H0 = np.asarray(B.INERTIA) * B.CASES[case].omega0
        assert np.linalg.norm(H0) == pytest.approx(h0, abs=5e-6)


def test_step_counts_are_theirs():
    """ceil(10 / dt) steps: their simTime column (printed to 6 digits) for every published row."""
    for r in B.published():
        assert B.step_count(r["dt"]) * r["dt"] == pytest.approx(r["sim_time"], abs=5e-5), r


def test_the_published_figures_are_the_ones_quoted_in_the_issue():
    pub = {(r["case"], r["engine"], r["dt"]): r for r in B.published()}
    assert len(pub) == 80
    quoted = {"ode": (0.0130708, 0.012462, 0.0012715, 0.00124711), "bullet": (0.0124501, 0.0135771, 0.00125827, 0.0013586),
              "simbody": (0.00643471, 0.00623355, 0.000634808, 0.00062358), "dart": (2.1861, 0.0376206, 2.22942, 0.0269129)}
    for engine, (h3, e3, h4, e4) in quoted.items():
        assert pub[("complex", engine, 0.001)]["momentum_error"] == h3
        assert pub[("complex", engine, 0.001)]["energy_error"] == e3
        assert pub[("complex", engine, 0.0001)]["momentum_error"] == h4
        assert pub[("complex", engine, 0.0001)]["energy_error"] == e4


def test_the_metrics_against_a_hand_computation():
    """A made-up run of three rows, its errors worked out by hand from the definitions."""
    case = B.CASES["complex"]
    I = np.asarray(B.INERTIA)
    w0 = np.asarray(case.omega0)
    eps = 1e-3
    # the body turned 90 deg about z with the rate scaled by (1 + eps): H = Rz(90) I w0 (1 + eps)
    q = np.array([[1, 0, 0, 0], [1, 0, 0, 0], [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)]])
    w = np.array([w0, w0, w0 * (1 + eps)])
    H0 = I * w0
    H2 = np.array([-H0[1], H0[0], H0[2]]) * (1 + eps)
    assert B.angular_momentum_error(q, w) == pytest.approx(np.linalg.norm(H2 - H0) / np.linalg.norm(H0), rel=1e-12)
    # energy: translation on the exact parabola at t = 0, 1, 2 s, plus the rotational energy's change
    t = np.array([0.0, 1.0, 2.0])
    T_rot = 0.5 * w0 @ (I * w0)
    assert B.energy_error(case, w, t=t) == pytest.approx(T_rot * ((1 + eps) ** 2 - 1) / case.energy0, rel=1e-9)
    # a centre of mass off the parabola by 1 cm in x at t = 1 s, a velocity off by 2 mm/s in z at t = 2 s
    g = np.asarray(case.gravity)
    c = np.asarray(case.v0) * t[:, None] + 0.5 * g * t[:, None] ** 2
    v = np.asarray(case.v0) + g * t[:, None]
    c[1, 0] += 0.01
    v[2, 2] += 0.002
    position, velocity = B.translation_errors(case, t, c, v)
    assert (position, velocity) == pytest.approx((0.01, 0.002), rel=1e-9)
    # the energy of that run: its kinetic energy off by m v_z dv + m dv^2 / 2, its potential unchanged
    E = B.energy(case, np.array([w0] * 3), c, v)
    assert E[2] - case.energy0 == pytest.approx(10 * v[2, 2] * 0.002 - 10 * 0.002 ** 2 / 2, rel=1e-6)


def test_mujocos_euler_is_odes_and_its_implicit_is_bullets():
    """At 1e-3 s on the complex case MuJoCo's first-order integrators reproduce the published figures of the engines
    that take the same step (semi-implicit Euler, gyroscopic term explicit / linearised) to 1 %; the translation's
    error is semi-implicit Euler's g dt T / 2 = 0.049 m."""
    pub = {r["engine"]: r for r in B.published() if r["case"] == "complex" and r["dt"] == 0.001}
    for integrator, engine in (("euler", "ode"), ("implicit", "bullet"), ("implicitfast", "bullet")):
        (row,) = mujoco_rows("complex", integrator, steps=(0.001,))
        assert row["momentum_error"] == pytest.approx(pub[engine]["momentum_error"], rel=0.01), integrator
        assert row["energy_error"] == pytest.approx(pub[engine]["energy_error"], rel=0.01), integrator
        assert row["position_error"] == pytest.approx(9.8 * 0.001 * 10 / 2, rel=1e-6)


def test_fourth_order_runs_keep_the_invariants_and_converge_at_order_4():
    """MuJoCo's RK4 and ours: relative invariant errors far below the bound, and the momentum error falling as dt^4
    between 1e-3 and 5e-4 s (above round-off there)."""
    steps = (0.001, 0.0007, 0.0005)
    rows = mujoco_rows("complex", "rk4", steps) + our_rows("complex", "lie-rkmk4", steps) \
        + our_rows("simple", "formulation-2", (0.001,))
    assert all(ok for _, ok, _ in checks(rows))
    for method in ("mujoco-rk4", "lie-rkmk4"):
        assert slope([r for r in rows if r["method"] == method], "momentum_error") == pytest.approx(4.0, abs=0.15)
    # and the bound can fail: a first-order row is not a fourth-order one, but a made-up bad RK4 row is caught
    bad = dict(rows[0], momentum_error=1e-6)
    assert not checks([bad])[0][1]


def test_the_league_ranks_by_the_momentum_error_at_the_coarsest_step():
    rows = mujoco_rows("complex", "euler", (0.001,)) + mujoco_rows("complex", "rk4", (0.001,))
    names = [e["name"] for e in entries(rows, "complex", (0.001,))]
    assert names[0] == "mujoco-rk4" and names[-1] == "DART"
    assert names.index("Simbody") < names.index("Bullet") < names.index("ODE")
    text = markdown(rows, (0.001,), version="x", versions={"mujoco": "m"}, command="xcheck league")
    assert "| 1 | mujoco-rk4 |" in text and "commit 55c3b05" in text


def test_xcheck_league_writes_the_table_and_its_figure(tmp_path, monkeypatch, capsys):
    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "docs" / "league.md"
    code = main(["league", "--steps", "0.001,0.0009", "--out", str(out), "--json", str(tmp_path / "league.json"),
                 "--workers", "1"])
    assert code == 0, capsys.readouterr().err
    text = out.read_text()
    assert "xcheck league --steps 0.001,0.0009 --out league.md" in text and "## Complex:" in text
    assert (out.parent / "boxes-league.png").read_bytes()[:4] == b"\x89PNG"
    import json

    doc = json.loads((tmp_path / "league.json").read_text())
    from xcheck.engines import available
    from xcheck.league.run import BULLET_PATHS, DRAKE_INTEGRATORS, EXUDYN_INTEGRATORS, OURS

    live = ((len(BULLET_PATHS) if available("pybullet") else 0) + available("dart")  # live engines' rows
            + (len(DRAKE_INTEGRATORS) if available("drake") else 0)
            + (len(EXUDYN_INTEGRATORS) if available("exudyn") else 0))
    assert len(OURS) == 12  # our fixed-step methods but the printed algorithm 172
    assert doc["schema"] == "xcheck.league/1" and len(doc["rows"]) == 2 * 2 * (4 + len(OURS) + live)


@pytest.mark.parametrize("args, said", [
    (["--steps", "0.1"], "--steps: 0.1 s is coarser than the boxes can be stepped"),
    (["--steps", "-1"], "--steps: '-1' is not a positive finite step"),
    (["--steps", "1e-9"], "--steps: 1e-09 s is finer than 1e-05 s"),
    (["--steps", "0.001", "--quick"], "--steps and --quick: give one"),
    (["--out", "league.txt"], "--out: league.txt must end in .md"),
    (["--steps", ""], "--steps: expected a comma-separated list (no empty item), got ''"),
    (["--steps", "1e-3,,2e-3"], "--steps: expected a comma-separated list (no empty item), got '1e-3,,2e-3'"),
    (["--out", "league.md"], "boxes-league.png"),  # its figure's path is a folder (made below): refused before work
])
def test_xcheck_league_refuses_bad_arguments(tmp_path, monkeypatch, capsys, args, said):
    from xcheck.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "boxes-league.png").mkdir()
    monkeypatch.setattr("xcheck.base.pool.worker_pool", lambda *a, **k: pytest.fail("work started before the refusal"))
    code = main(["league", *args])
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err, err


def test_files_written_together_take_ctrl_c_after_the_last():
    """A Ctrl-C while the league writes its JSON, table and figure arrives after all three (each alone atomic; a
    JSON without its table once said no report was written): the interrupt is held, then delivered. In a process
    of its own, whose main thread takes the signal as the command's does (pytest-xdist's worker may not)."""
    import subprocess
    import sys

    code = ("import os, signal\nfrom xcheck.base.interrupts import signals_deferred\nwritten = []\ntry:\n"
            "    with signals_deferred():\n        os.kill(os.getpid(), signal.SIGINT)\n"
            "        written += ['json', 'md']\nexcept KeyboardInterrupt:\n    print('interrupted after', written)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "interrupted after ['json', 'md']", out.stderr
