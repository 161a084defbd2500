"""Issue 27: MuJoCo's ball-joint conventions, pinned down before the heavy top is built on them (facts of the
installed MuJoCo, asserted rather than assumed).

* A ball joint's ``qpos`` (4, scalar first) is the rotation *relative to the body's reference orientation* (its
  ``quat`` in the MJCF): the world attitude is ``quat ⊗ qpos`` (a free joint's is the world attitude itself).
* Its ``qvel`` (3) is the angular velocity in the body frame (ours: body rates in the body frame).
* Gravity's generalized force on it (``qfrc_bias`` at rest) is minus the torque about the pivot,
  τ = c × (m Rᵀ g) in body components, c the centre of mass from the pivot: the heavy top's torque."""

import mujoco
import numpy as np

from xcheck import rotations as rot

Q_REF = rot.rotvec_to_quat(0.7 * np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9]))
TOP = """<mujoco>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="top" pos="0 0 1" quat="{q}">
      <joint name="pivot" type="ball" pos="0 0 0"/>
      <inertial pos="0.02 -0.01 0.3" mass="1.5" diaginertia="0.01 0.02 0.03"/>
    </body>
  </worldbody>
</mujoco>"""


def _model():
    return mujoco.MjModel.from_xml_string(TOP.format(q=" ".join(repr(float(x)) for x in Q_REF)))


def test_a_ball_joints_qpos_is_relative_to_the_bodys_reference_orientation():
    m = _model()
    d = mujoco.MjData(m)
    np.testing.assert_array_equal(d.qpos, [1.0, 0.0, 0.0, 0.0])  # the reference pose is qpos = identity
    q_rel = rot.rotvec_to_quat(np.array([0.4, 0.0, 0.0]))
    d.qpos[:] = q_rel
    mujoco.mj_forward(m, d)
    want = rot.quat_mul(Q_REF, q_rel)
    assert min(np.abs(d.xquat[1] - want).max(), np.abs(d.xquat[1] + want).max()) < 1e-15


def test_a_ball_joints_qvel_is_the_body_frame_rate():
    m = _model()
    d = mujoco.MjData(m)
    d.qpos[:] = rot.rotvec_to_quat(np.array([0.0, 1.1, 0.0]))
    omega = np.array([0.3, -1.2, 2.5])
    d.qvel[:] = omega
    mujoco.mj_forward(m, d)
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, 1, vel, 0)  # world frame: [angular, linear]
    R = d.xmat[1].reshape(3, 3)  # body -> world, like our R
    np.testing.assert_allclose(vel[:3], R @ omega, rtol=0, atol=1e-14)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, 1, vel, 1)  # local (body) frame
    np.testing.assert_allclose(vel[:3], omega, rtol=0, atol=1e-14)


def test_gravitys_generalized_force_is_the_heavy_tops_torque_about_the_pivot():
    m = _model()
    d = mujoco.MjData(m)
    d.qpos[:] = rot.rotvec_to_quat(0.5 * np.array([0.6, 0.8, 0.0]))
    mujoco.mj_forward(m, d)
    R = d.xmat[1].reshape(3, 3)
    c = m.body_ipos[1]  # the centre of mass from the pivot (the joint at the body origin), body frame
    tau = np.cross(c, m.body_mass[1] * R.T @ m.opt.gravity)
    np.testing.assert_allclose(-d.qfrc_bias, tau, rtol=1e-13, atol=1e-15)


def test_the_gravity_torque_model_is_mujocos_gravity_on_the_ball_joint():
    """xcheck's GravityTorque (the compiled dipole-in-a-uniform-field kernel with M_p = c, mu0 H = m g) against
    MuJoCo's own gravity on the ball joint, at five attitudes, and against c x (m R^T g) written out."""
    from xcheck.fields import GravityTorque

    m = _model()
    d = mujoco.MjData(m)
    torque = GravityTorque(m.body_ipos[1], m.body_mass[1], m.opt.gravity)
    assert torque.attitude_dependent
    rng = np.random.default_rng(27)
    for _ in range(5):
        q_rel = rot.quat_normalize(rng.normal(size=4))
        d.qpos[:] = q_rel
        mujoco.mj_forward(m, d)
        q_world = d.xquat[1].copy()  # body -> world: the attitude our torque models read
        R = rot.quat_to_dcm(q_world)
        got = torque(0.0, q_world, np.zeros(3))
        np.testing.assert_allclose(got, np.cross(m.body_ipos[1], m.body_mass[1] * R.T @ m.opt.gravity), rtol=1e-14,
                                   atol=1e-15)
        np.testing.assert_allclose(got, -d.qfrc_bias, rtol=1e-12, atol=1e-14)


def test_a_gravity_torque_with_no_mass_is_refused_naming_it():
    import pytest

    from xcheck.fields import GravityTorque

    with pytest.raises(ValueError, match="mass: expected a positive finite mass in kg, got 0.0"):
        GravityTorque([0, 0, 0.1], 0.0, [0, 0, -9.81])
    with pytest.raises(ValueError, match="gravity: expected a finite"):
        GravityTorque([0, 0, 0.1], 1.0, [0, float("nan"), -9.81])
