"""The torque PyBullet, DART and Drake apply (xcheck.engines.held_input.engine_torque): compiled from a torque model,
in world components, from each engine's own form of the state. Truth: the model's own body-frame torque at the
body's attitude (xcheck.rotations, numpy), rotated into the world by hand; tolerance 1e-15 relative (round-off of
one rotation and one product)."""

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.engines.held_input import engine_torque
from xcheck.fields import GravityGradientTorque, MagneticTorque, OrbitDipoleField, SumTorque, UniformField

RNG = np.random.default_rng(40)
MODELS = {
    "magnet in a uniform field": MagneticTorque([0.5, -0.2, 0.3], UniformField([2e4, -1e4, 3e4])),
    "magnet in the orbit dipole": MagneticTorque([0.1, 0.2, 1.0], OrbitDipoleField()),
}
MODELS["gravity gradient and a magnet"] = SumTorque([GravityGradientTorque(np.diag([1.0, 2.0, 3.0])),
                                                     MODELS["magnet in a uniform field"]])


def _state():
    q = rot.quat_normalize(RNG.normal(size=4))
    V = rot.quat_to_dcm(rot.quat_normalize(RNG.normal(size=4)))  # a principal frame off the body
    return q, RNG.normal(size=3), V


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("form, rates", [("xyzw", "world"), ("wxyz", "world"), ("dcm", "body"), ("rotvec", "world")])
def test_world_torque_from_each_engines_state(name, form, rates):
    model = MODELS[name]
    for _ in range(5):
        q, w_body, V = _state()
        t = float(RNG.uniform(0, 100))
        truth = rot.quat_to_dcm(q) @ model(t, q, w_body)
        qV = rot.dcm_to_quat(V)
        frame = rot.quat_mul(q, qV) if form == "xyzw" else q  # Bullet's principal frame; the others: the body
        att = {"xyzw": np.r_[frame[1:], frame[:1]], "wxyz": frame, "dcm": rot.quat_to_dcm(frame).ravel(),
               "rotvec": rot.quat_to_rotvec(frame)}[form]
        w = rot.quat_rotate(q, w_body) if rates == "world" else w_body
        right = rot.quat_conj(qV) if form == "xyzw" else None
        for how, torque in (("compiled", model), ("interpreted", lambda t, q, w: model(t, q, w))):
            got = engine_torque(torque, form=form, right=right, rates=rates)(t, att, w)
            assert np.allclose(got, truth, rtol=0, atol=1e-15 * np.linalg.norm(truth) * 8), (how, got, truth)


def test_the_model_reads_the_body_rate():
    """The world rate is turned into body components before the model reads it (a probe records what it reads)."""
    seen = []
    probe = lambda t, q, w: (seen.append(np.array(w)), np.zeros(3))[1]  # noqa: E731
    q, w_body, _ = _state()
    engine_torque(probe, form="wxyz", rates="world")(0.0, q, rot.quat_rotate(q, w_body))
    assert np.allclose(seen[0], w_body, rtol=0, atol=1e-14)


def test_unknown_form_is_refused_by_name():
    with pytest.raises(ValueError, match="form/rates"):
        engine_torque(MODELS["magnet in a uniform field"], form="xyz", rates="world")
