"""The root-joint table: what differs between a planar and a free-flying base, tested for both
roots by the same parametrized tests."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.errors import ParameterError
from ffsm_pin.robot import ROOTS, Robot, load_robot

SPATIAL9 = {"urdf": "spatial9.urdf", "end_effector": "ee"}


@pytest.fixture(scope="module", params=["planar", "free-flyer"])
def robot(request) -> Robot:
    if request.param == "planar":
        return load_robot("ffsm_planar4.urdf")
    return load_robot(
        "example-robot-data:panda",
        "panda_hand",
        base="free-flyer",
        locked_joints={"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.02},
    )


def _pose(robot: Robot, rng) -> np.ndarray:
    if robot.base == "planar":
        return np.array([*rng.uniform(-2, 2, 2), rng.uniform(-math.pi, math.pi)])
    s = rng.normal(size=3)
    s *= rng.uniform(0.05, 0.95) / np.linalg.norm(s)  # |s| < 1: the reported branch
    return np.concatenate((rng.uniform(-2, 2, 3), s))


def test_sizes_follow_the_root(robot):
    root = robot.root
    assert ROOTS[robot.base] is root
    assert robot.model.nq == root.nq + robot.n_joints
    assert robot.model.nv == root.nv + robot.n_joints
    assert robot.model.joints[1].nq == root.nq and robot.model.joints[1].nv == root.nv
    assert robot.joint_names == tuple(robot.model.names[2:])
    assert robot.model.gravity.linear.tolist() == [0.0, 0.0, 0.0]


def test_configuration_places_the_base(robot, rng):
    """The base frame Pinocchio computes from q is the pose that was asked for."""
    data = robot.model.createData()
    for _ in range(5):
        pose = _pose(robot, rng)
        joints = rng.uniform(-1, 1, robot.n_joints)
        q = robot.configuration(pose, joints)
        pin.forwardKinematics(robot.model, data, q)
        oMb = data.oMi[1]
        np.testing.assert_array_equal(q[robot.root.nq :], joints)
        if robot.base == "planar":
            np.testing.assert_allclose(oMb.translation[:2], pose[:2], atol=1e-15)
            yaw = math.atan2(oMb.rotation[1, 0], oMb.rotation[0, 0])
            assert yaw == pytest.approx(pose[2], abs=1e-14)
        else:
            np.testing.assert_allclose(oMb.translation, pose[:3], atol=1e-15)
            np.testing.assert_allclose(oMb.rotation, mrp.to_rotation(pose[3:]), atol=1e-14)


def test_wrong_joint_count_is_one_error_class(robot):
    """The same mistake gets the same exception class on both roots."""
    pose = np.zeros(robot.root.nq - 1 if robot.base == "planar" else 6)
    with pytest.raises(ParameterError, match=f"expected {robot.n_joints} joint angles"):
        robot.configuration(pose, np.zeros(robot.n_joints - 1))


def test_options_only_where_the_root_supports_them():
    assert ROOTS["free-flyer"].options and not ROOTS["planar"].options
    with pytest.raises(ValueError, match="apply only to base 'free-flyer'"):
        load_robot("ffsm_planar4.urdf", locked_joints={"joint1": 0.0})


def test_one_class_and_old_names():
    """The 0.1.0 class names and the spatial loader resolve to the one class and loader."""
    from ffsm_pin import FreeFloatingRobot
    from ffsm_pin.robot import SpatialRobot, load_spatial_robot

    assert FreeFloatingRobot is Robot and SpatialRobot is Robot
    robot = load_spatial_robot(**SPATIAL9)
    assert isinstance(robot, Robot) and robot.base == "free-flyer"
