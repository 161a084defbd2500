"""MJCF loading: the bundled models, inertia from any <inertial> orientation, and every refusal."""

import warnings

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.engines.mujoco import simulate
from xcheck.integrators import integrate
from xcheck.models import ModelError, load_body
from xcheck.paths import BUNDLED_MODELS

GYRO = BUNDLED_MODELS / "gyroscope.xml"
RAX1 = BUNDLED_MODELS / "rax1.xml"


def mjcf(body="", world="", option='<option gravity="0 0 0"><flag contact="disable"/></option>', extra=""):
    return f"""<mujoco model="test">
  {option}
  {extra}
  <worldbody>
    {world}
    <body name="b">
      <freejoint/>
      <inertial pos="0 0 0" mass="1" diaginertia="1 2 2.5"/>
      {body}
    </body>
  </worldbody>
</mujoco>"""


@pytest.fixture
def write(tmp_path):
    def _write(text, name="model.xml"):
        path = tmp_path / name
        path.write_text(text)
        return path
    return _write


def test_bundled_gyroscope_is_seed001():
    b = load_body(GYRO)
    m, r = 2.0, 0.075
    np.testing.assert_allclose(b.inertia, np.diag([0.5 * m * r**2, 0.25 * m * r**2, 0.25 * m * r**2]), rtol=1e-15)
    assert b.mass == 2.0 and b.name == "gyroscope" and not np.any(b.dipole) and b.notes == ()


def test_bundled_rax1_is_seed004():
    b = load_body(RAX1)
    np.testing.assert_allclose(b.inertia, np.diag([0.018, 0.018, 0.006]), rtol=1e-15)  # eq. 176
    np.testing.assert_allclose(b.dipole, [0.14, 0.02, 1.09], rtol=1e-15)  # eq. 175
    assert b.name == "rax1"


@pytest.mark.parametrize("inertial", [
    '<inertial pos="0 0 0" mass="1" fullinertia="{xx} {yy} {zz} {xy} {xz} {yz}"/>',
    '<inertial pos="0.01 -0.02 0.03" mass="1" quat="{qw} {qx} {qy} {qz}" diaginertia="1 2 2.5"/>',
])
def test_rotated_inertia_comes_out_right_and_mujoco_agrees_with_lie(write, inertial):
    q_in = rot.quat_normalize([0.9, 0.3, -0.2, 0.25])
    R = rot.quat_to_dcm(q_in)
    tensor = R @ np.diag([1.0, 2.0, 2.5]) @ R.T
    text = inertial.format(xx=tensor[0, 0], yy=tensor[1, 1], zz=tensor[2, 2], xy=tensor[0, 1], xz=tensor[0, 2],
                           yz=tensor[1, 2], qw=q_in[0], qx=q_in[1], qy=q_in[2], qz=q_in[3])
    path = write(mjcf().replace('<inertial pos="0 0 0" mass="1" diaginertia="1 2 2.5"/>', text))
    body = load_body(path)
    np.testing.assert_allclose(body.inertia, tensor, atol=1e-12)
    q0 = rot.quat_normalize([0.8, 0.1, -0.4, 0.3])
    w0 = np.array([0.3, 1.1, -0.6])
    ours = integrate("lie-rkmk4", body.inertia, q0, w0, dt=1 / 256, duration=10.0)
    theirs = simulate(path, integrator="rk4", q0=q0, omega0=w0, dt=1 / 256, duration=10.0)
    assert rot.attitude_error(ours.q, theirs.q).max() < 1e-9


def test_any_single_free_body_works_with_default_contacts(write):
    """A body alone in the world, contacts left enabled: nothing can collide, so it is accepted."""
    path = write(mjcf(body='<geom type="sphere" size="0.1" mass="0"/>', option=""))
    with pytest.warns(UserWarning, match="gravity .* switched off"):
        body = load_body(path)
    assert body.notes and "no torque about the centre of mass" in body.notes[0]


@pytest.mark.parametrize("text, match", [
    ('<mujoco><worldbody><body><geom size="0.1"/></body></worldbody></mujoco>', "no free joint"),
    (mjcf(world='<body name="d"><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>'),
     "a multi-body model: 2 moving bodies and 2 joints \\(2 free\\); xcheck checks one rigid body"),
    (mjcf(world='<body name="h"><joint name="hinge" type="hinge"/><inertial pos="0 0 0" mass="1" '
               'diaginertia="1 1 1"/></body>'), "a multi-body model: 2 moving bodies and 2 joints \\(1 hinge, 1 free\\)"),
    (mjcf(world='<body name="e"><inertial pos="1 0 0" mass="1" diaginertia="1 1 1"/></body>',
          extra='<equality><weld body1="b" body2="e"/></equality>'), "equality constraint"),
    (mjcf(body='<geom name="g1" type="sphere" size="0.1" mass="0"/>', world='<geom name="floor" type="plane" '
          'size="1 1 0.1"/>', option='<option gravity="0 0 0"/>'),
     "contacts are enabled and geoms 'floor' and 'g1' can collide"),
    (mjcf(extra='<actuator><motor joint="j"/></actuator>').replace("<freejoint/>", '<freejoint name="j"/>'),
     "actuator"),
    (mjcf(option='<option gravity="0 0 0" density="1.2"><flag contact="disable"/></option>'),
     "fluid forces would add torque"),
    (mjcf().replace("<freejoint/>", '<joint type="free" damping="0.1"/>'), "the free joint has damping"),
    (mjcf(extra='<custom><numeric name="xcheck_dipole" data="1 2"/></custom>'),
     'numeric name="xcheck_dipole"> has 2 values; expected 3'),
    (mjcf().replace('diaginertia="1 2 2.5"', 'diaginertia="1 1 3"'),
     "(?s)MuJoCo could not load it: .*inertia must satisfy A \\+ B >= C.*line 6"),
    ("<mujoco>\n<worldbody>\n<body>\n<freejoint/>\n</wrongtag>\n</mujoco>",
     "(?s)MuJoCo could not load it: XML parse error.*Line number=3"),
])
def test_refusals_name_the_file_and_the_reason(write, text, match):
    path = write(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ModelError, match=match) as info:
            load_body(path)
    assert str(path) in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(ModelError, match="no such MJCF file"):
        load_body(tmp_path / "absent.xml")
