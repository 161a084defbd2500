"""Field and torque models against independent formulas, the thesis's initial torque, and bad tables."""

import numpy as np
import pytest

from xcheck import rotations as rot
from xcheck.fields import (
    MU0,
    SEED004_INITIAL_TORQUE,
    BodyFieldTable,
    IGRFField,
    MagneticTorque,
    OrbitDipoleField,
    UniformField,
    WorldFieldTable,
    load_field_table,
    magnetic_torque,
    nearest_achievable_torque,
    orbit_position,
    rax1_orbit_phase_residual,
    rax1_synthetic_body_table,
)
from xcheck.paths import BUNDLED_MODELS

M_P = np.array([0.14, 0.02, 1.09])  # seed 004 eq. 175
P0 = np.array([-0.4583, -0.6558, 0.5997, 0.0182])  # eq. 178
TABLE = BUNDLED_MODELS / "rax1_field_body.csv"


def test_printed_initial_torque_is_not_a_dipole_torque():
    """eq. 177 has a 2.0e-9 N m component along M_p, which mu0 M_p x H cannot have (4-digit rounding)."""
    nearest, distance = nearest_achievable_torque(M_P, SEED004_INITIAL_TORQUE)
    assert distance == pytest.approx(2.0016e-9, rel=1e-4)
    assert abs(np.dot(nearest, M_P)) < 1e-22


def test_bundled_body_table_reproduces_the_nearest_achievable_torque():
    table = load_field_table(TABLE)
    np.testing.assert_allclose(table, rax1_synthetic_body_table(), rtol=1e-11, atol=1e-9)  # 12 digits written
    nearest, _ = nearest_achievable_torque(M_P, SEED004_INITIAL_TORQUE)
    torque0 = MagneticTorque(M_P, BodyFieldTable(table))(0.0, [1.0, 0, 0, 0], np.zeros(3))
    assert np.abs(torque0 - nearest).max() < 1e-12  # issue 4: to 1e-12 N m
    B = MU0 * np.linalg.norm(table[:, 1:], axis=1)
    assert table[0, 0] == 0.0 and table[-1, 0] == 500.0
    assert B[0] == pytest.approx(35e-6, rel=1e-9) and 30e-6 < B.min() and B.max() < 40e-6


def test_orbit_dipole_default_phase_reproduces_the_thesis_torque():
    torque, distance, B0 = rax1_orbit_phase_residual()
    assert distance < 2.01e-9  # of which 2.0016e-9 no dipole torque can remove
    assert 20e-6 < B0 < 50e-6


def test_orbit_dipole_field_is_a_dipole():
    """Independent check: the IGRF 2010 dipole strength B0 = |(g10, g11, h11)| = 29.95 µT at R_E on the
    magnetic equator, 2 B0 at the magnetic poles, falling as r^-3; and the kernel's field along the orbit
    equals (3 (m.r^) r^ - m) mu0 / (4 pi r^3) evaluated here with numpy."""
    field = OrbitDipoleField(earth_angle_deg=0.0)
    m = field.moment
    B0 = MU0 * np.linalg.norm(m) / (4 * np.pi * 6371.2e3**3)
    assert B0 == pytest.approx(29.95e-6, rel=1e-3)
    t = np.array([0.0, 100.0, 2000.0])
    r = orbit_position(t, 650.0, 72.0, field.raan_deg, field.arg_latitude_deg)
    g = 7.2921150e-5 * t
    m_eci = np.stack([np.cos(g) * m[0] - np.sin(g) * m[1], np.sin(g) * m[0] + np.cos(g) * m[1],
                      np.full_like(g, m[2])], axis=1)
    rn = np.linalg.norm(r, axis=1, keepdims=True)
    rhat = r / rn
    H = (3 * np.sum(m_eci * rhat, axis=1, keepdims=True) * rhat - m_eci) / (4 * np.pi * rn**3)
    np.testing.assert_allclose(field.H_world(t), H, rtol=1e-12)
    np.testing.assert_allclose(rn[:, 0], 6371.2e3 + 650e3)


@pytest.mark.parametrize("field", [UniformField([20.0, -10.0, 15.0]), OrbitDipoleField(),
                                   BodyFieldTable(rax1_synthetic_body_table()),
                                   WorldFieldTable(rax1_synthetic_body_table())])
def test_torque_kernel_matches_numpy(field):
    torque = MagneticTorque(M_P, field)
    rng = np.random.default_rng(3)
    for t in (0.0, 0.25, 3.7, 9.9):
        q = rot.quat_normalize(rng.normal(size=4))
        if isinstance(field, UniformField):
            H_body = rot.quat_rotate(rot.quat_conj(q), field.H_world)
        elif isinstance(field, OrbitDipoleField):
            H_body = rot.quat_rotate(rot.quat_conj(q), field.H_world(np.array([t]))[0])
        elif isinstance(field, WorldFieldTable):
            H_body = rot.quat_rotate(rot.quat_conj(q), field.H_body(t))
        else:
            H_body = field.H_body(t)
        np.testing.assert_allclose(torque(t, q * 2.0, np.zeros(3)), magnetic_torque(M_P, H_body), rtol=1e-12,
                                   atol=1e-20)
    assert torque.attitude_dependent == (not type(field) is BodyFieldTable)


def test_igrf_along_the_orbit_is_close_to_its_dipole():
    pytest.importorskip("ppigrf")
    igrf = IGRFField(duration=20.0)
    dipole = OrbitDipoleField()
    H_igrf = igrf.T[:, 1:]
    H_dip = dipole.H_world(igrf.T[:, 0])
    ratio = np.linalg.norm(H_igrf, axis=1) / np.linalg.norm(H_dip, axis=1)
    angle = np.arccos(np.sum(H_igrf * H_dip, axis=1) / np.linalg.norm(H_igrf, axis=1) / np.linalg.norm(H_dip, axis=1))
    assert np.all((0.5 < ratio) & (ratio < 1.5)) and np.all(angle < np.radians(40))
    assert np.all(np.diff(igrf.T[:, 0]) == 0.5)


@pytest.mark.parametrize("text, match", [
    ("0,1,2,3\n1,1,2\n", r"line 2: expected 4 columns"),
    ("0,1,2,3\n1,1,2,x\n", r"line 2: expected 4 numbers"),
    ("0,1,2,3\n0,1,2,3\n", r"strictly increasing"),
    ("# only\n0,1,2,3\n", r"at least 2 rows"),
    ("0,1,2,3\n1,nan,2,3\n", r"line 2: non-finite"),
])
def test_bad_tables_name_the_file_and_line(tmp_path, text, match):
    path = tmp_path / "field.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=match) as info:
        load_field_table(path)
    assert str(path) in str(info.value)


def test_table_header_and_comments_are_skipped(tmp_path):
    path = tmp_path / "field.csv"
    path.write_text("# a comment\nt,Hx,Hy,Hz\n0,1,2,3\n0.5,2,3,4\n")
    np.testing.assert_array_equal(load_field_table(path), [[0, 1, 2, 3], [0.5, 2, 3, 4]])


@pytest.mark.parametrize("kwargs, match", [
    (dict(altitude_km=-5.0), "altitude_km: expected a positive altitude"),
    (dict(inclination_deg=np.nan), "inclination_deg: expected a finite angle"),
])
def test_bad_orbit_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        OrbitDipoleField(**kwargs)


# ------------------------------------------------------------------------------------------------
# one declaration per field model (issue 9)
# ------------------------------------------------------------------------------------------------
def _instances():
    from xcheck.fields import FIELDS

    table = rax1_synthetic_body_table()
    made = {"body-table": BodyFieldTable(table), "world-table": WorldFieldTable(table),
            "orbit-dipole": OrbitDipoleField(), "uniform": UniformField([20.0, -10.0, 15.0])}
    assert set(made) | {"igrf"} == set(FIELDS)  # a new field must be added here too
    return made


def test_every_field_declares_its_slots_keys_and_frame():
    """Truth: each declaration. The packed parameters are evaluator, frame, then exactly the declared slots;
    the compiled kernel's attitude answer is the declaration's frame."""
    from xcheck.fields import FIELDS, kernel, torque_needs_attitude

    for name, field in _instances().items():
        assert FIELDS[name] is type(field) and field.name == name
        assert list(field.slot_values()) == list(field.slots)
        P = MagneticTorque(M_P, field).P
        assert P[kernel.EVALUATOR] == field.evaluator and len(P) == kernel.FIELD + len(field.slots)
        assert bool(torque_needs_attitude(kernel.MAGNETIC, P)) == field.attitude_dependent == (field.frame == "world")
        assert set(field.keys) <= set(FIELDS[name].keys) and all(k.kind in ("number", "vector3", "string", "path")
                                                                 for k in field.keys.values())


def test_a_field_added_by_its_declaration_and_registry_entry_alone(tmp_path, monkeypatch):
    """Adding a field = its class + one FIELDS entry: the scenario reader, the torque builder and the messages
    pick it up. Here a constant field in BODY components (the existing constant evaluator, frame "body"):
    with the identity attitude it must give the same torque as the uniform world field, and unlike it the
    torque must not depend on attitude."""
    from xcheck import fields, scenario
    from xcheck.fields import Field, Key, kernel

    class BodyUniformField(Field):
        name = "body-uniform"
        keys = {"H_body": Key("vector3", required=True)}
        slots = ("Hx", "Hy", "Hz")
        frame = "body"
        evaluator = kernel.CONSTANT_FIELD

        def __init__(self, H_body):
            self.H = np.asarray(H_body, float)

        def slot_values(self):
            return dict(zip(self.slots, self.H.tolist()))

    monkeypatch.setitem(fields.FIELDS, "body-uniform", BodyUniformField)
    model = BUNDLED_MODELS / "rax1.xml"
    path = tmp_path / "s.toml"
    path.write_text(f'name = "s"\nmodel = "{model}"\nduration = 1.0\n[initial]\nquaternion = [1, 0, 0, 0]\n'
                    'angular_velocity = [0.1, 0, 0]\n[torque]\nkind = "magnetic"\nfield = "body-uniform"\n'
                    'H_body = [20.0, -10.0, 15.0]\n[study]\nreference = "dop853"\n')
    s = scenario.load_scenario(path)
    assert s.torque == {"kind": "magnetic", "field": "body-uniform", "H_body": [20.0, -10.0, 15.0]}
    from xcheck.models import load_body

    from xcheck.assembly import build_torque

    torque = build_torque(s, load_body(model))
    world = MagneticTorque(torque.dipole, UniformField([20.0, -10.0, 15.0]))
    np.testing.assert_array_equal(torque(0.0, [1.0, 0, 0, 0], np.zeros(3)), world(0.0, [1.0, 0, 0, 0], np.zeros(3)))
    q = rot.quat_normalize([0.3, 0.5, -0.2, 0.7])
    np.testing.assert_array_equal(torque(0.0, q, np.zeros(3)), torque(0.0, [1.0, 0, 0, 0], np.zeros(3)))
    assert not torque.attitude_dependent and world.attitude_dependent
    # its required key is enforced, and the list of fields in messages includes it
    path.write_text(path.read_text().replace("H_body = [20.0, -10.0, 15.0]\n", ""))
    with pytest.raises(scenario.ScenarioError, match=r"\[torque\] H_body: missing"):
        scenario.load_scenario(path)
    path.write_text(path.read_text().replace('"body-uniform"', '"nonesuch"'))
    with pytest.raises(scenario.ScenarioError, match=r"\[torque\] field: expected one of .*'body-uniform'"):
        scenario.load_scenario(path)
