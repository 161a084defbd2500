"""The surface forces of LEO (issue 28): solar radiation pressure and aerodynamic drag as a force through a centre
of pressure, against hand computations, seed 004 Table 1's sizes, their invariants and the scenario keys."""

from __future__ import annotations

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.fields import AerodynamicTorque, SolarPressureTorque
from xcheck.fields.orbit import RAX1_ORBIT, orbit_position
from xcheck.integrators import integrate
from xcheck.metrics import invariant_changes
from xcheck.scenario import ScenarioError, resolve_scenario
from xcheck.study.context import run_context

RAX1 = np.diag([0.018, 0.018, 0.006])
ATTITUDES = [rot.quat_normalize(q) for q in ([1.0, 0, 0, 0], [0.9, 0.1, 0.2, -0.3], [0.1, -0.7, 0.5, 0.4])]


def test_solar_pressure_is_the_force_through_its_centre_by_hand():
    """Truth: tau = c x (R^T F), F = -P C_r A s, by hand at three attitudes; RAX-1's size (a 0.03 m^2 side, the
    centre of pressure 0.1 m off) is seed 004 Table 1's 2e-8 N m within a factor of 2."""
    c, s = np.array([0.0, 0.02, 0.1]), np.array([0.0, 0.6, 0.8])
    tq = SolarPressureTorque(c, 0.03, reflectivity=1.5, sun_direction=s)
    F = -4.56e-6 * 1.5 * 0.03 * s
    for q in ATTITUDES:
        want = np.cross(c, rot.quat_to_dcm(q).T @ F)
        np.testing.assert_allclose(tq(0.0, q, np.zeros(3)), want, rtol=0, atol=1e-13 * np.linalg.norm(want))
    assert 1e-8 < np.linalg.norm(tq(0.0, ATTITUDES[1], np.zeros(3))) < 4e-8


def test_drag_turns_with_the_orbits_velocity():
    """Truth: the orbit's velocity by a central difference of its position (orbit_position), the speed sqrt(mu /
    a), rho v^2 / 2 C_d A; RAX-1's size (1e-13 kg/m^3 at 650 km, 1 cm offset) is Table 1's 2e-9 N m within 2x."""
    c = np.array([0.0, 0.01, 0.0])
    tq = AerodynamicTorque(c, 0.03, density=1e-13, drag_coefficient=2.2)
    keys = {k: RAX1_ORBIT[k] for k in ("altitude_km", "inclination_deg", "raan_deg", "arg_latitude_deg")}
    for t, q in zip((0.0, 100.0, 2000.0), ATTITUDES):
        h = 1e-3
        v = (orbit_position([t + h], **keys)[0] - orbit_position([t - h], **keys)[0]) / (2 * h)
        F = -0.5 * 1e-13 * (v @ v) * 2.2 * 0.03 * v / np.linalg.norm(v)
        np.testing.assert_allclose(tq(t, q, np.zeros(3)), np.cross(c, rot.quat_to_dcm(q).T @ F), rtol=1e-7)
    assert 5e-10 < np.linalg.norm(tq(0.0, ATTITUDES[1], np.zeros(3))) < 4e-9


def test_solar_pressure_keeps_what_a_fixed_force_keeps():
    """Truth: a force fixed in the world through a fixed offset is a top's gravity: T + V and the momentum along
    the sun's direction are conserved (to round-off at a fine step)."""
    tq = SolarPressureTorque([0.01, 0.02, 0.1], 3.0, sun_direction=[0.0, 0.0, 1.0], pressure=1e-3)  # made large
    run = integrate("lie-rkmk4", RAX1, ATTITUDES[1], [0.05, -0.02, 0.1], dt=1 / 64, duration=20.0, torque=tq)
    drift = invariant_changes(RAX1, run, tq)
    assert abs(drift["energy_change"]) < 1e-12 and abs(drift["momentum_change"]) < 1e-12


def test_a_scenario_sums_every_leo_torque(tmp_path):
    """The four torques of seed 004 Table 1 in one [[torque]] list, each term's keys read and refused by name."""
    text = ('name = "leo"\nmodel = "{model}"\nduration = 2.0\n[initial]\nquaternion = [1, 0, 0, 0]\n'
            'angular_velocity = [0.01, 0.02, 0.03]\n'
            '[[torque]]\nkind = "magnetic"\nfield = "orbit-dipole"\n[[torque]]\nkind = "gravity-gradient"\n'
            '[[torque]]\nkind = "solar-pressure"\ncentre_of_pressure = [0.0, 0.02, 0.1]\narea = 0.03\n'
            '[[torque]]\nkind = "aerodynamic"\ncentre_of_pressure = [0.0, 0.01, 0.0]\narea = 0.03\n{extra}'
            '[study]\nreference = "dop853"\n')
    from xcheck.paths import BUNDLED_MODELS

    path = tmp_path / "leo.toml"
    path.write_text(text.format(model=BUNDLED_MODELS / "rax1.xml", extra=""))
    ctx = run_context(resolve_scenario(str(path)))
    assert [type(t).__name__ for t in ctx.torque.terms] == ["MagneticTorque", "GravityGradientTorque",
                                                           "SolarPressureTorque", "AerodynamicTorque"]
    q, w = ATTITUDES[2], np.array([0.01, 0.02, 0.03])
    np.testing.assert_allclose(ctx.torque(1.0, q, w), sum(t(1.0, q, w) for t in ctx.torque.terms), rtol=1e-13)
    bad = text.format(model=BUNDLED_MODELS / "rax1.xml", extra="").replace("area = 0.03\n[[torque]]\nkind = \"aero",
                                                                         "[[torque]]\nkind = \"aero")
    path.write_text(bad)
    with pytest.raises(ScenarioError, match=r"leo.toml: \[torque\[2\]\] area: missing"):
        resolve_scenario(str(path))


def test_basilisk_holds_drag_at_the_midpoint_and_writes_solar_pressure_once():
    from xcheck.engines.basilisk import input_order

    assert input_order("solar-pressure") is None and input_order("aerodynamic") == 2
