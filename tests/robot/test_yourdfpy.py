"""Pinocchio's forward kinematics of the URDFs agree with yourdfpy's (an independent parser and
kinematics implementation)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

from ffsm_pin.robot import load_robot

# Both sides compose a handful of 4x4 rigid transforms in double precision: the results agree
# to a few ulps of the reach (~7 m); 1e-12 absolute is ~1000 ulps of it.
TOL = 1e-12
N_CONFIGS = 10

URDFS = ["ffsm_planar4.urdf", "planar5_collinear.urdf", "planar5_offaxis.urdf"]


@pytest.fixture(scope="module", params=URDFS)
def pair(request, data_dir):
    """(FreeFloatingRobot, yourdfpy.URDF) of one file."""
    robot = load_robot(request.param, relative_to=data_dir)
    urdf = yourdfpy.URDF.load(str(robot.urdf_path), load_meshes=False, build_scene_graph=True)
    return robot, urdf


def _pin_frame(robot, data, name):
    oMf = data.oMf[robot.model.getFrameId(name)]
    return oMf.homogeneous


def test_every_link_and_the_end_effector(pair):
    robot, urdf = pair
    model = robot.model
    data = model.createData()
    rng = np.random.default_rng(42)
    joint_names = list(model.names[2:])
    assert sorted(urdf.actuated_joint_names) == sorted(joint_names)
    links = list(urdf.link_map)
    assert set(robot.body_names) <= set(links)
    for _ in range(N_CONFIGS):
        angles = dict(zip(joint_names, rng.uniform(-np.pi, np.pi, len(joint_names)), strict=True))
        # Pinocchio: planar base at the identity, q = (0, 0, cos 0, sin 0, q_m)
        q = np.concatenate(([0.0, 0.0, 1.0, 0.0], [angles[j] for j in joint_names]))
        pin.framesForwardKinematics(model, data, q)
        urdf.update_cfg(np.array([angles[j] for j in urdf.actuated_joint_names]))
        for link in links:
            expected = urdf.get_transform(frame_to=link, frame_from=urdf.base_link)
            np.testing.assert_allclose(_pin_frame(robot, data, link), expected, rtol=0, atol=TOL)
        # the end-effector frame (a fixed joint for Pinocchio) is the ee link's origin
        expected = urdf.get_transform(frame_to="ee_link", frame_from=urdf.base_link)
        np.testing.assert_allclose(
            data.oMf[robot.ee_frame_id].homogeneous, expected, rtol=0, atol=TOL
        )


def test_moving_base(pair):
    """With the base at (x, y, q_b), every frame is the base pose times yourdfpy's transform."""
    robot, urdf = pair
    model = robot.model
    data = model.createData()
    rng = np.random.default_rng(7)
    joint_names = list(model.names[2:])
    for _ in range(N_CONFIGS):
        angles = rng.uniform(-np.pi, np.pi, len(joint_names))
        x, y, qb = rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-np.pi, np.pi)
        pin.framesForwardKinematics(model, data, robot.configuration((x, y, qb), angles))
        urdf.update_cfg(np.array([angles[joint_names.index(j)] for j in urdf.actuated_joint_names]))
        base = np.eye(4)
        base[:2, :2] = [[np.cos(qb), -np.sin(qb)], [np.sin(qb), np.cos(qb)]]
        base[:2, 3] = x, y
        expected = base @ urdf.get_transform(frame_to="ee_link", frame_from=urdf.base_link)
        np.testing.assert_allclose(
            data.oMf[robot.ee_frame_id].homogeneous, expected, rtol=0, atol=TOL
        )
