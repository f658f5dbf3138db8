"""The compiled MRP kernels the spatial sensor uses (ffsm_pin/attitude/_mrp_kernels.py) against
the numpy reference (ffsm_pin/attitude/mrp.py), and the compiled measurement against the
reference formulas of docs/spatial.md section 1 on a real free-flyer state."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import _mrp_kernels as fast
from ffsm_pin.attitude import mrp

TOL = {"rtol": 1e-13, "atol": 1e-15}  # the same formulas; only the order of additions differs


def _random_mrps(rng, n=200):
    s = rng.normal(size=(n, 3))
    return s / np.maximum(1.0, np.linalg.norm(s, axis=1))[:, None]  # on the |s| <= 1 branch


def test_from_quaternion_and_to_rotation(rng):
    for s in _random_mrps(rng):
        quat = mrp.to_quaternion(s)
        for sign in (1.0, -1.0):  # -quat is the same rotation: the same MRP
            got = fast.from_quaternion(*(sign * quat))
            np.testing.assert_allclose(got, mrp.from_quaternion(sign * quat), **TOL)
        np.testing.assert_allclose(fast.to_rotation(s), mrp.to_rotation(s), **TOL)


@pytest.mark.parametrize("angle", [0.3, 2.0, 3.1, np.pi], ids=["small", "large", "near-pi", "pi"])
def test_from_rotation_every_branch(rng, angle):
    """Rotations by ``angle`` about random axes and about each coordinate axis: Shepperd's
    four branches (trace, or the largest diagonal entry) all taken."""
    axes = [*rng.normal(size=(20, 3)), *np.eye(3)]
    for axis in axes:
        R = pin.exp3(angle * axis / np.linalg.norm(axis))
        got = fast.from_rotation(R)
        np.testing.assert_allclose(got, mrp.from_rotation(R), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(mrp.to_rotation(got), R, atol=1e-13)  # a true inverse


def test_kinematics_rate(rng):
    for s in _random_mrps(rng, 50):
        R = mrp.to_rotation(s)
        w = rng.normal(size=3)
        np.testing.assert_allclose(fast.kinematics_rate(s, R, w), mrp.L_matrix(s, R) @ w, **TOL)


def test_spatial_measurement_equals_the_reference_formulas(rng):
    """The sensor's compiled arithmetic against mrp.py on a 3-joint free-flyer chain."""
    from ffsm_pin.sim._sensor_kernels import spatial_measurement

    ff = pin.Model()  # a free-flyer base and three revolute joints
    base = ff.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    ff.appendBodyToJoint(base, pin.Inertia.Random(), pin.SE3.Identity())
    parent = base
    for k in range(3):
        parent = ff.addJoint(parent, pin.JointModelRZ(), pin.SE3.Random(), f"j{k}")
        ff.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
    fid = ff.addFrame(pin.Frame("ee", parent, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    data = ff.createData()
    for _ in range(10):
        q, v = pin.randomConfiguration(ff, -np.ones(ff.nq), np.ones(ff.nq)), rng.normal(size=ff.nv)
        pin.forwardKinematics(ff, data, q, v)
        oMf = pin.updateFramePlacement(ff, data, fid)
        vel = pin.getFrameVelocity(ff, data, fid, pin.LOCAL_WORLD_ALIGNED)
        q_b, R0, z_e, z_e_dot, w = spatial_measurement(q, v, oMf.homogeneous, vel.vector)
        np.testing.assert_allclose(q_b, mrp.from_quaternion(q[3:7]), **TOL)
        np.testing.assert_allclose(R0, pin.Quaternion(q[3:7]).toRotationMatrix(), atol=1e-13)
        q_e = mrp.from_rotation(oMf.rotation)
        np.testing.assert_allclose(z_e, np.concatenate((oMf.translation, q_e)), **TOL)
        rate = mrp.L_matrix(q_e, oMf.rotation) @ vel.angular
        np.testing.assert_allclose(z_e_dot, np.concatenate((vel.linear, rate)), **TOL)
        np.testing.assert_allclose(w, np.concatenate((R0 @ v[3:6], v[6:])), **TOL)
