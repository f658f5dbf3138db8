"""``[target]``: a rigid body beside a free-flyer robot, tumbling torque-free (issue 40).

The run builds it as a :class:`ffsm_pin.sim.target.Target` box and its initial
:class:`~ffsm_pin.sim.target.TargetState` (:mod:`ffsm_pin.sim.target_run`); docs/capture.md.
"""

from __future__ import annotations

from dataclasses import dataclass

#: The target's shapes (``[target] shape``).
TARGET_SHAPES = ("box",)
#: What ``[target] position`` is relative to: the world origin, or the end effector's
#: position at t = 0 (world axes).
TARGET_ORIGINS = ("world", "end-effector")


@dataclass(frozen=True)
class TargetSpec:
    """``[target]``: a box tumbling torque-free (free-flyer robots only).

    Attributes
    ----------
    size : tuple of float
        Edges (a, b, c) of a box centred on the target frame [m].
    mass : float
        [kg].
    position : tuple of float
        The target frame's origin (the box's centre) [m]: in the world, or relative to the
        end effector's position at t = 0 (``origin``), world axes.
    shape : str
        ``"box"``.
    inertia : tuple of float or None
        ixx, iyy, izz, ixy, ixz, iyz about its CoM along the target frame [kg m^2]; None: the
        uniform box's.
    attitude_rpy : tuple of float
        Roll-pitch-yaw of the target frame in the world [rad].
    velocity : tuple of float
        The CoM's velocity, world frame [m/s].
    angular_velocity : tuple of float
        Body-frame angular velocity [rad/s].
    origin : str
        ``"world"`` or ``"end-effector"`` (:data:`TARGET_ORIGINS`).
    grasp_xyz, grasp_rpy : tuple of float
        The grasp frame in the target frame [m], [rad]; inside the box.
    """

    size: tuple[float, ...]
    mass: float
    position: tuple[float, ...]
    shape: str = "box"
    inertia: tuple[float, ...] | None = None
    attitude_rpy: tuple[float, ...] = (0.0, 0.0, 0.0)
    velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    origin: str = "world"
    grasp_xyz: tuple[float, ...] = (0.0, 0.0, 0.0)
    grasp_rpy: tuple[float, ...] = (0.0, 0.0, 0.0)
