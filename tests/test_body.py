"""Rigid bodies (xcheck.body): physical inertia only (positive, triangle inequality), tensors of any
orientation reduced to principal axes with a proper rotation."""

import numpy as np
import pytest

from xcheck.body import RigidBody, principal_axes, validate_inertia
from xcheck.rotations import quat_to_dcm


def test_moments_become_a_tensor():
    np.testing.assert_array_equal(validate_inertia([1.0, 2.0, 3.0]), np.diag([1.0, 2.0, 3.0]))
    validate_inertia([1.0, 1.0, 2.0])  # a thin plate: equality in the triangle inequality


@pytest.mark.parametrize("inertia, match", [
    ([1.0, 2.0, 4.0], r"I3 = 4 exceeds I1 \+ I2 = 3"),
    ([0.0, 1.0, 1.0], "I1 = 0 kg m\\^2 must be positive"),
    ([1.0, np.nan, 1.0], "non-finite"),
    ([[1, 0.5, 0], [0, 1, 0], [0, 0, 1]], "not symmetric"),
    ([1.0, 2.0], r"got shape \(2,\)"),
    ("heavy", "expected principal moments"),
])
def test_unphysical_inertia_is_refused(inertia, match):
    with pytest.raises(ValueError, match=match):
        validate_inertia(inertia)


def test_rotated_tensor_recovers_its_principal_axes():
    """Truth: T = R diag(1, 2, 3) R^T for a known rotation R; eigh gives the moments and a proper V."""
    R = quat_to_dcm(np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2]))
    T = R @ np.diag([1.0, 2.0, 3.0]) @ R.T
    moments, V = principal_axes(validate_inertia(T))
    np.testing.assert_allclose(moments, [1.0, 2.0, 3.0], rtol=1e-14)
    assert np.linalg.det(V) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(V @ np.diag(moments) @ V.T, T, atol=1e-14)


def test_diagonal_tensor_keeps_its_axes():
    moments, V = principal_axes(np.diag([3.0, 1.0, 2.0]))
    np.testing.assert_array_equal(moments, [1.0, 2.0, 3.0])
    assert np.linalg.det(V) == 1.0 and np.abs(V).sum() == 3.0


def test_rigid_body_checks_dipole_and_mass():
    body = RigidBody(inertia=[0.018, 0.018, 0.006], dipole=[0.14, 0.02, 1.09], mass=4.0)
    np.testing.assert_array_equal(body.principal_moments, [0.006, 0.018, 0.018])
    with pytest.raises(ValueError, match="dipole: expected a finite"):
        RigidBody(inertia=[1, 1, 1], dipole=[np.inf, 0, 0])
    with pytest.raises(ValueError, match="mass: expected a positive"):
        RigidBody(inertia=[1, 1, 1], mass=-1.0)
