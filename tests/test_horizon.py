"""The horizon study (issue 41; ``xcheck horizon``, :mod:`xcheck.study.horizon`): the growth laws are fitted as the
theory has them, on synthetic data with a known law and on real runs: a Runge-Kutta method's energy drifts
secularly on the heavy top, the variational integrator's stays bounded; the crossing times are read as stated."""

from __future__ import annotations

import json

import numpy as np
import pytest

from xcheck.scenario import resolve_scenario
from xcheck.study.horizon import drift_law, growth_exponent, log_indices, run_horizon, time_within


def test_the_fits_recover_known_laws():
    """Truth: data made from the law. ``e = 3e-9 t^2`` fits p = 2 (to 1e-9); a drift oscillating within a fixed
    envelope is bounded, one growing as t secular (q within 0.05 of 1), one as sqrt(t) neither (q = 0.5);
    round-off (1e-12) is said to be round-off."""
    t = np.geomspace(0.01, 1e4, 200)
    assert growth_exponent(t, 3e-9 * t ** 2) == pytest.approx(2.0, abs=1e-9)
    assert growth_exponent(t, np.full_like(t, 1e-15)) is None  # at round-off: no law
    wobble = 1e-5 * (1.5 + np.sin(37 * t))
    assert drift_law(t, wobble)[0] == "bounded"
    law, q = drift_law(t, 1e-9 * t)
    assert law == "secular" and q == pytest.approx(1.0, abs=0.05)
    law, q = drift_law(t, 1e-7 * np.sqrt(t))
    assert law.startswith("grows as t^0.5") and q == pytest.approx(0.5, abs=0.05)
    assert drift_law(t, np.full_like(t, 1e-12))[0] == "round-off"


def test_time_within_is_the_last_time_before_the_first_crossing():
    t = np.arange(6.0)
    assert time_within(t, [0, 1e-7, 5e-7, 2e-6, 1e-7, 3e-6], 1e-6) == 2.0  # a later dip back does not count
    assert time_within(t, np.zeros(6), 1e-6) == 5.0
    assert time_within(t, [2e-6] * 6, 1e-6) == 0.0
    assert list(log_indices(1000, 5)) == [1, 6, 32, 178, 1000]


def test_on_the_heavy_top_rk4s_energy_drifts_and_the_variational_integrators_stays_bounded():
    """Truth: Lagrange's top in closed form over 600 s (about 210 precessions) at 1/128 s. lie-rkmk4's energy error
    is secular (q = 1.05 within 0.1), its attitude error grows as t^1.36 (between 1 and 2) and stays within 1e-3 rad
    for 517 s; lie-lgvi's energy error is bounded (|q| < 0.1), while its attitude error, second order on a 15.7
    rad/s spin, passes 1e-3 rad within the first tenth of a second."""
    res = run_horizon(resolve_scenario("heavy-top"), duration=600.0, steps=(1 / 128,),
                      methods=["lie-rkmk4", "lie-lgvi"])
    rk, lgvi = res.lines
    assert rk.status == lgvi.status == "ok"
    assert rk.energy_law == "secular" and rk.energy_exponent == pytest.approx(1.05, abs=0.1)
    assert 1.0 < rk.growth < 2.0
    assert rk.within[1e-6] < rk.within[1e-3] == pytest.approx(517, rel=0.02)
    assert lgvi.energy_law == "bounded" and abs(lgvi.energy_exponent) < 0.1
    assert lgvi.within[1e-3] < 0.1
    assert len(rk.t) == len(rk.attitude_error) == len(rk.energy_drift) and rk.t[-1] == 600.0


def test_xcheck_horizon_prints_the_laws_and_writes_them(tmp_path, capsys):
    from xcheck.cli import main

    out = tmp_path / "h.json"
    code = main(["horizon", "heavy-top", "--duration", "1min", "--steps", "0.0078125",
                 "--methods", "lie-rkmk4,mujoco-euler", "--json", str(out), "--out", str(tmp_path / "figs")])
    text = capsys.readouterr().out
    assert code == 0
    assert "heavy-top over 60 s" in text and "lie-rkmk4" in text and "secular" in text
    doc = json.loads(out.read_text())
    assert doc["schema"] == "xcheck.horizon/1" and doc["duration"] == 60.0 and len(doc["lines"]) == 2
    assert set(doc["lines"][0]["within"]) == {"1e-06", "0.001"}
    assert (tmp_path / "figs" / "heavy-top-horizon.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args, words", [(["--duration", "a week"], "--duration: expected a positive time"),
                                         (["--duration=-3h"], "--duration: expected a positive time"),
                                         (["--steps", "0"], "--steps:"),
                                         (["--methods", "nope"], "--methods:")])
def test_bad_arguments_are_refused_by_name(args, words, capsys):
    from xcheck.cli import main

    code = main(["horizon", "heavy-top", *args])
    assert code == 2 and words in capsys.readouterr().err
