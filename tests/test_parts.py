"""Issue 27, bodies built from parts: a free body whose child bodies have no joints is one rigid body.

Truths: a hand-written parallel-axis sum over the parts' own numbers (masses, centres, inertias, poses written in
the MJCF below); MuJoCo's own joint-space mass matrix (``mj_fullM``), whose rotational block of a free joint is the
whole body's inertia about the joint's origin in the body frame; and a torque-free study, where MuJoCo (which
simulates the parts as the bodies they are) and our integrators (on the composite inertia) must agree."""

import math

import mujoco
import numpy as np
import pytest

from xcheck.models import ModelError, composite_inertia, load_body, load_mujoco

pytestmark = pytest.mark.filterwarnings("ignore:.*welded into one rigid body")  # the model's note, by design

# a bus (2 kg box), a solar panel (0.5 kg, off to the side, turned 30 deg about x) and an antenna on the panel
# (0.1 kg point-like rod, 90 deg about z from the panel)
SATELLITE = """<mujoco model="parts">
  <option gravity="0 0 0"><flag contact="disable"/></option>
  <worldbody>
    <body name="bus">
      <freejoint/>
      <inertial pos="0.01 -0.02 0.03" mass="2.0" diaginertia="0.02 0.03 0.04"/>
      <body name="panel" pos="0.3 0 0.05" quat="{c30} {s30} 0 0">
        <inertial pos="0.1 0 0" mass="0.5" diaginertia="0.001 0.004 0.005"/>
        <body name="antenna" pos="0.2 0.05 0" quat="{c45} 0 0 {s45}">
          <inertial pos="0 0 0.1" mass="0.1" diaginertia="0.0004 0.0004 0.00001"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
""".format(c30=math.cos(math.radians(15)), s30=math.sin(math.radians(15)), c45=math.cos(math.radians(45)),
           s45=math.sin(math.radians(45)))


@pytest.fixture
def parts(tmp_path):
    path = tmp_path / "parts.xml"
    path.write_text(SATELLITE)
    return path


def _rx(deg):
    a = math.radians(deg)
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def _rz(deg):
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def test_the_composite_is_the_parallel_axis_sum_by_hand(parts):
    R_panel, R_ant = _rx(30), _rx(30) @ _rz(90)
    p_panel = np.array([0.3, 0, 0.05])
    p_ant = p_panel + R_panel @ [0.2, 0.05, 0]
    m = np.array([2.0, 0.5, 0.1])
    c = np.array([[0.01, -0.02, 0.03], p_panel + R_panel @ [0.1, 0, 0], p_ant + R_ant @ [0, 0, 0.1]])
    own = [np.diag([0.02, 0.03, 0.04]), R_panel @ np.diag([0.001, 0.004, 0.005]) @ R_panel.T,
           R_ant @ np.diag([0.0004, 0.0004, 0.00001]) @ R_ant.T]
    com = m @ c / m.sum()
    want = sum(I + mi * ((ci - com) @ (ci - com) * np.eye(3) - np.outer(ci - com, ci - com))
               for I, mi, ci in zip(own, m, c))
    body = load_body(parts)
    np.testing.assert_allclose(body.inertia, want, rtol=0, atol=1e-15)
    assert body.mass == pytest.approx(2.6, rel=1e-15)
    model, _ = load_mujoco(parts)
    mass, got_com, _ = composite_inertia(model, body.body_id)
    np.testing.assert_allclose(got_com, com, rtol=0, atol=1e-15)


def test_the_composite_is_mujocos_own_mass_matrix(parts):
    """MuJoCo's free-joint mass matrix block at the root's origin: I_C + M (|c|^2 E - c c^T)."""
    model, body = load_mujoco(parts)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    for i in range(model.nv):  # column by column through mj_mulM, whatever the release stores M as
        e = np.zeros(model.nv)
        e[i] = 1.0
        column = np.zeros(model.nv)
        mujoco.mj_mulM(model, data, column, e)
        M[:, i] = column
    rot_block = M[body.dof_adr + 3:body.dof_adr + 6, body.dof_adr + 3:body.dof_adr + 6]
    mass, com, I_c = composite_inertia(model, body.body_id)
    np.testing.assert_allclose(I_c + mass * (com @ com * np.eye(3) - np.outer(com, com)), rot_block, rtol=1e-12,
                               atol=1e-15)
    np.testing.assert_allclose(data.subtree_com[body.body_id], com, rtol=0, atol=1e-15)


def test_a_model_built_of_parts_is_cross_checked(parts):
    """Torque free from a tumble: MuJoCo on its three bodies and our methods on the composite agree (the
    study's agreement check, 1e-9 rad) and converge at their orders against the exact reference."""
    from xcheck.scenario import resolve_scenario
    from xcheck.study import run_study

    sc = resolve_scenario(str(parts))
    st = run_study(sc, methods=["lie-rkmk4", "mujoco-rk4", "mujoco-euler"], quick=True, workers=1, timing=False)
    assert st.passed, [(c.name, c.note) for c in st.checks if not c.passed]
    assert st.methods["mujoco-rk4"].finest.attitude_error < 1e-11


def test_a_part_with_a_joint_of_its_own_is_refused(tmp_path):
    """A part that moves on its own is another body: refused, naming its joint. A hinge is taken for a wheel's
    (issue 28), and this one carries the antenna: not a wheel."""
    path = tmp_path / "hinged.xml"
    path.write_text(SATELLITE.replace('<body name="panel" pos', '<body name="panel" pos').replace(
        '<inertial pos="0.1 0 0"', '<joint name="hinge" type="hinge"/><inertial pos="0.1 0 0"'))
    with pytest.raises(ModelError, match="hinge joint 'hinge' \\(body 'panel'; a hinge is a wheel's here\\): a wheel has no "
                                         "bodies below it"):
        load_body(path)
