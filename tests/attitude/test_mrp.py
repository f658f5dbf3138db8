"""MRP identities (docs/spatial.md section 5) against Pinocchio's rotations."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp


@pytest.fixture
def rotations(rng):
    return [pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3)) for _ in range(20)]


def test_rotation_round_trips_and_branch(rotations):
    for R in rotations:
        s = mrp.from_rotation(R)
        assert s @ s <= 1.0 + 1e-15
        assert np.abs(mrp.to_rotation(s) - R).max() < 1e-14
        quat = mrp.to_quaternion(s)
        assert np.abs(pin.Quaternion(quat).toRotationMatrix() - R).max() < 1e-14
        assert np.abs(mrp.from_quaternion(quat) - s).max() < 1e-14


def test_angle_of_mrp_is_four_arctan():
    # s = e tan(phi/4): a rotation by phi about e
    axis = np.array([2.0, -1.0, 0.5]) / np.linalg.norm([2.0, -1.0, 0.5])
    for phi in (0.1, 1.0, 2.5, 3.1):
        s = axis * np.tan(phi / 4)
        assert np.abs(mrp.to_rotation(s) - pin.exp3(axis * phi)).max() < 1e-14


def test_shadow_set_is_the_same_attitude(rng):
    for _ in range(20):
        s = rng.uniform(-3, 3, 3)
        sh = mrp.shadow(s)
        assert sh @ sh <= 1.0 + 1e-15
        assert np.abs(mrp.to_rotation(sh) - mrp.to_rotation(s)).max() < 1e-13


def test_L_times_L_transpose(rng):
    # L_b L_b^T = ((1 + s^T s) / 4)^2 E_3 (so lambda_b = 1/16 bounds it from below)
    for _ in range(20):
        s = rng.uniform(-1.5, 1.5, 3)
        L = mrp.L_matrix(s)
        assert np.abs(L @ L.T - ((1 + s @ s) / 4) ** 2 * np.eye(3)).max() < 1e-14


def test_kinematics_against_finite_differences(rng):
    """ds/dt = L_b w (w inertial) along R(t) = exp([w] t) R: central differences of the MRP."""
    h = 1e-5  # 5-point stencil: truncation ~ h^4, rounding ~ 1e-16 / h ~ 1e-11
    for _ in range(10):
        R = pin.rpy.rpyToMatrix(*rng.uniform(-2, 2, 3))
        w = rng.normal(size=3)
        s = mrp.from_rotation(R)

        def f(t, w=w, R=R):
            return mrp.from_rotation(pin.exp3(w * t) @ R)

        fd = (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)
        assert np.abs(fd - mrp.L_matrix(s) @ w).max() < 1e-9


def test_from_rpy_matches_pinocchio(rng):
    rpy = rng.uniform(-1, 1, 3)
    assert np.abs(mrp.to_rotation(mrp.from_rpy(rpy)) - pin.rpy.rpyToMatrix(*rpy)).max() < 1e-14


def test_analytic_branch_agrees_with_pinocchio(rotations):
    """from_rotation's complex-safe path (Shepperd's four branches) gives the real path's MRP,
    including rotations by nearly pi about each axis (the branches with a small trace)."""
    extra = [pin.exp3(np.pi * 0.999 * e) for e in np.eye(3)]
    for R in [*rotations, *extra]:
        s_complex = mrp.from_rotation(R.astype(complex))
        assert np.abs(s_complex.imag).max() == 0.0
        assert np.abs(s_complex.real - mrp.from_rotation(R)).max() < 1e-13


def test_angles_from_is_the_angle_of_the_relative_rotation(rotations, rng):
    """The rotation from R0 to R0 exp([e]x phi) (in either branch of each MRP) is by phi."""
    for R0 in rotations:
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        phis = rng.uniform(0.0, np.pi, 8)
        s_rows = np.array([mrp.from_rotation(R0 @ pin.exp3(phi * axis)) for phi in phis])
        s_rows[::2] = [mrp.shadow(s) for s in s_rows[::2]]  # the same attitudes, other branch
        angles = mrp.angles_from(s_rows, mrp.from_rotation(R0))
        np.testing.assert_allclose(angles, phis, atol=1e-7)  # (acos near 0 and pi: ~sqrt(eps))
