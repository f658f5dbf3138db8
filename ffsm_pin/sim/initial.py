"""The initial plant state of a scenario: Pinocchio (q, v) from its ``[initial]`` table,
planar or free-flyer (docs/cli.md, docs/spatial.md section 1)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..attitude import mrp
from ..errors import ScenarioError
from ..model._state_planar import base_twist_to_local
from ..robot import Robot
from ..scenario.spec import InitialCondition


def initial_state(robot: Robot, init: InitialCondition) -> tuple[np.ndarray, np.ndarray]:
    """Pinocchio (q, v) from an :class:`InitialCondition` (see its docstring).

    Parameters
    ----------
    robot : Robot
        The robot.
    init : InitialCondition
        The scenario's initial condition.

    Returns
    -------
    q, v : ndarray
        The initial state (Pinocchio convention).
    """
    return _INITIAL_STATE[robot.base](robot, init)


def _initial_state_planar(robot: Robot, init: InitialCondition) -> tuple[np.ndarray, np.ndarray]:
    model = robot.model
    data = model.createData()
    _check_joint_lists(robot, init)
    pose = np.array(init.base_pose, dtype=float)
    if init.attitude_error is not None:  # an angle added to q_b
        pose[2] += float(np.asarray(init.attitude_error, dtype=float).reshape(-1)[0])
    q = robot.configuration(pose, init.joints)
    if init.com_at_origin:
        com = pin.centerOfMass(model, data, q)
        q[0] -= com[0]
        q[1] -= com[1]
    v = np.zeros(model.nv)
    v[3:] = init.joint_rates
    if init.base_twist is not None:
        v[:3] = base_twist_to_local(q, init.base_twist)
        return q, v
    # unknown base twist (local) from CoM velocity and base rate or angular momentum
    Jcom = pin.jacobianCenterOfMass(model, data, q)[:2]
    Ag = pin.computeCentroidalMap(model, data, q)[5]
    vcom = np.asarray(init.com_velocity, dtype=float)
    if init.base_rate is not None:
        v[2] = init.base_rate
        v[:2] = np.linalg.solve(Jcom[:, :2], vcom - Jcom[:, 2:] @ v[2:])
    else:
        A = np.vstack((Jcom[:, :3], Ag[None, :3]))
        rhs = np.concatenate((vcom - Jcom[:, 3:] @ v[3:], [init.angular_momentum - Ag[3:] @ v[3:]]))
        v[:3] = np.linalg.solve(A, rhs)
    return q, v


def _check_joint_lists(robot: Robot, init: InitialCondition, prefix: str = "") -> None:
    """initial.joints and initial.joint_rates have one entry per joint; the error names the
    list that is wrong and the joints."""
    n = robot.n_joints
    for name, vec in (("joints", init.joints), ("joint_rates", init.joint_rates)):
        if len(vec) != n:
            raise ScenarioError(
                f"initial.{name} has {len(vec)} entries, robot {robot.name!r} has {n} joints "
                f"({prefix}{', '.join(robot.joint_names)})"
            )


def _sized(value, n: int, key: str) -> np.ndarray:
    vec = np.atleast_1d(np.asarray(value, dtype=float))
    if vec.shape != (n,):
        raise ScenarioError(f"initial.{key} has {vec.size} values, a free-flyer base needs {n}")
    return vec


def _initial_state_spatial(robot: Robot, init: InitialCondition):
    """Free-flyer (q, v): base_pose = (x, y, z, MRP); velocities in the inertial frame,
    converted to Pinocchio's base-frame twist (docs/spatial.md section 1)."""
    model = robot.model
    data = model.createData()
    _check_joint_lists(robot, init, "unlocked: ")
    pose = np.asarray(init.base_pose, dtype=float)
    if pose.shape != (6,):
        raise ScenarioError(
            f"initial.base_pose has {pose.size} values, a free-flyer base needs 6 "
            "(x, y, z [m], then the attitude as an MRP s1, s2, s3)"
        )
    if pose[3:] @ pose[3:] > 1.0:
        raise ScenarioError(
            f"initial.base_pose: attitude MRP {pose[3:].tolist()} has |s| > 1; give the "
            "shadow MRP -s / |s|^2 (|s| <= 1)"
        )
    if init.attitude_error is not None:  # R(0) = exp([e]x) R(base_pose), MRP |s| <= 1
        turn = pin.exp3(_sized(init.attitude_error, 3, "attitude_error"))
        pose = np.concatenate((pose[:3], mrp.from_rotation(turn @ mrp.to_rotation(pose[3:]))))
    q = robot.configuration(pose, init.joints)
    if init.com_at_origin:
        q[:3] -= pin.centerOfMass(model, data, q)
    R0 = mrp.to_rotation(pose[3:])
    v = np.zeros(model.nv)
    v[6:] = init.joint_rates
    if init.base_twist is not None:
        twist = _sized(init.base_twist, 6, "base_twist")
        v[:3], v[3:6] = R0.T @ twist[:3], R0.T @ twist[3:]
        return q, v
    mass = robot.geometry.total_mass
    vcom = _sized(init.com_velocity, 3, "com_velocity")
    Ag = pin.computeCentroidalMap(model, data, q)  # h_g = (P, L about the CoM) = Ag v
    if init.base_rate is not None:
        v[3:6] = R0.T @ _sized(init.base_rate, 3, "base_rate")
        v[:3] = np.linalg.solve(Ag[:3, :3], mass * vcom - Ag[:3, 3:] @ v[3:])
    else:
        h = np.concatenate((mass * vcom, _sized(init.angular_momentum, 3, "angular_momentum")))
        v[:6] = np.linalg.solve(Ag[:, :6], h - Ag[:, 6:] @ v[6:])
    return q, v


# root joint (``robot.base``) -> how its initial state is built
_INITIAL_STATE = {"planar": _initial_state_planar, "free-flyer": _initial_state_spatial}
