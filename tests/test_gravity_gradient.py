"""Issue 28, a first step: the gravity-gradient torque of low Earth orbit, tau = 3 mu / r^3 (o x I o), against a hand
computation at three attitudes, through a scenario to our integrators (fourth order against DOP853), MuJoCo (the
same numbers as lie-rkmk4's scheme) and Basilisk (its own effector), and summed with the magnetic
torque (the sum is the terms added)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.fields import GravityGradientTorque, SumTorque
from xcheck.fields.orbit import MU_EARTH, RAX1_ORBIT, orbit_position
from xcheck.runners import RUNNERS
from xcheck.scenario import ScenarioError, resolve_scenario
from xcheck.study import run_study
from xcheck.study.context import run_context

RAX1_INERTIA = np.array([[0.018, 0.001, 0.0], [0.001, 0.018, 0.0005], [0.0, 0.0005, 0.006]])


def test_the_gravity_gradient_torque_is_its_formula_written_out():
    """Truth: 3 mu / a^3 (o x I o), o = R^T (-r/|r|), r the orbit position of fields.orbit_position (the orbit of the
    orbit field models), at three attitudes and times; its size on RAX-1 is seed 004 Table 1's (3e-8 N m)."""
    gg = GravityGradientTorque(RAX1_INERTIA)
    rng = np.random.default_rng(3)
    orbit = {k: RAX1_ORBIT[k] for k in ("altitude_km", "inclination_deg", "raan_deg", "arg_latitude_deg")}
    for _ in range(3):
        q, t = rot.quat_normalize(rng.normal(size=4)), rng.uniform(0.0, 100.0)
        r = orbit_position([t], **orbit)[0]
        o = rot.quat_to_dcm(q).T @ (-r / np.linalg.norm(r))
        want = 3 * MU_EARTH / np.linalg.norm(r) ** 3 * np.cross(o, RAX1_INERTIA @ o)
        np.testing.assert_allclose(gg(t, q, np.zeros(3)), want, rtol=1e-13, atol=1e-24)
        assert 1e-9 < np.linalg.norm(want) < 1e-7
    # torque free about a principal axis along the nadir: no torque
    diag = GravityGradientTorque(np.diag([0.018, 0.018, 0.006]))
    o_world = diag.nadir_world(0.0)
    axis = np.cross([0.0, 0.0, 1.0], o_world)
    q = rot.rotvec_to_quat(axis / np.linalg.norm(axis) * np.arccos(o_world[2]))  # body z onto the nadir
    assert np.linalg.norm(diag(0.0, q, np.zeros(3))) < 1e-22


def _scenario(tmp_path, torque: str):
    model = resolve_scenario("rax1-orbit-field").model
    path = tmp_path / "gg.toml"
    path.write_text(f'name = "gg"\nmodel = "{model}"\nduration = 10.0\n[initial]\nquaternion = [-0.4583, -0.6558, '
                    f'0.5997, 0.0182]\nangular_velocity_deg = [15.0, -10.0, 5.0]\n{torque}\n[study]\n'
                    'reference = "dop853"\nquick_steps = [0.5, 0.25, 0.125, 0.0625]\n')
    return resolve_scenario(str(path))


def test_a_scenario_in_the_gravity_gradient_runs_every_engine_to_its_order(tmp_path):
    """RAX-1 in its orbit's gravity gradient: our RK4 methods and MuJoCo's at order 4 against DOP853, MuJoCo's RK4
    lie-rkmk4's scheme to round-off; Basilisk's own GravityGradientEffector, the orbit flown inside Basilisk, at
    order 4 too (nothing held)."""
    sc = _scenario(tmp_path, '[torque]\nkind = "gravity-gradient"')
    ctx = run_context(sc)
    assert isinstance(ctx.torque, GravityGradientTorque)
    methods = ["lie-rkmk4", "formulation-2", "mrp-rk4", "mujoco-rk4"] + (["basilisk-rk4"] if "basilisk-rk4" in RUNNERS
                                                                         else [])
    st = run_study(sc, methods=methods, quick=True, workers=1, timing=False)
    assert st.passed, [c.to_json() for c in st.checks if not c.passed]
    for m in ("lie-rkmk4", "formulation-2", "mrp-rk4", "mujoco-rk4"):
        assert st.methods[m].observed_order == pytest.approx(4.0, abs=0.1), m
    for a, b in zip(st.methods["mujoco-rk4"].runs, st.methods["lie-rkmk4"].runs):
        assert a.attitude_error == pytest.approx(b.attitude_error, rel=1e-6)
    if "basilisk-rk4" in RUNNERS:
        assert st.methods["basilisk-rk4"].expected_order == 4
        assert st.methods["basilisk-rk4"].observed_order == pytest.approx(4.0, abs=0.1)


def test_the_gravity_gradient_sums_with_the_magnetic_torque(tmp_path):
    """A sum of the orbit field's magnetic torque and the gravity gradient is the two evaluated apart and added (to
    round-off), at every attitude; a scenario's torque keys are checked by name."""
    field = run_context(resolve_scenario("rax1-orbit-field")).torque
    gg = GravityGradientTorque(RAX1_INERTIA)
    both = SumTorque([field, gg])
    assert both.attitude_dependent
    rng = np.random.default_rng(5)
    for _ in range(4):
        q, t, w = rot.quat_normalize(rng.normal(size=4)), rng.uniform(0, 10), rng.normal(size=3)
        np.testing.assert_allclose(both(t, q, w), field(t, q, w) + gg(t, q, w), rtol=1e-15, atol=1e-24)
    with pytest.raises(ScenarioError, match="altitude_km: expected a positive altitude"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _scenario(tmp_path, '[torque]\nkind = "gravity-gradient"\naltitude_km = -5.0')
    with pytest.raises(ScenarioError, match="expected one of 'magnetic', 'constant', 'gravity-gradient'"):
        _scenario(tmp_path, '[torque]\nkind = "solar"')
