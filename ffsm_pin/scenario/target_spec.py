"""``[target]``: a rigid body beside a free-flyer robot, tumbling torque-free, and
``[capture]``: when the hand grasps it (issue 40).

The run builds it as a :class:`ffsm_pin.sim.target.Target` box and its initial
:class:`~ffsm_pin.sim.target.TargetState` (:mod:`ffsm_pin.sim.target_run`); with
``[capture]`` the loop grasps it (:mod:`ffsm_pin.sim.capture_run`); docs/capture.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The target's shapes (``[target] shape``).
TARGET_SHAPES = ("box",)
#: What ``[target] position`` is relative to: the world origin, or the end effector's
#: position at t = 0 (world axes).
TARGET_ORIGINS = ("world", "end-effector")
#: What the controller is told of the target after capture (``[capture] estimates``).
CAPTURE_ESTIMATES = ("unknown", "perturbed", "true")
#: [rad/s] ``[capture] detumble_rate``'s default: the held target's rate relative to the bus
#: below which it counts as detumbled (0.1 degree per second).
DETUMBLE_RATE = math.radians(0.1)
#: The ``[approach.noise]`` keys of the target's sensor, in the order the noise is drawn.
APPROACH_NOISE_KEYS = ("position", "attitude", "velocity", "angular_velocity")


@dataclass(frozen=True)
class CaptureSpec:
    """``[capture]``: the hand grasps the target when the two grasp frames are within the
    tolerances (checked once per control period on the true state; docs/capture.md).

    Attributes
    ----------
    tolerance_position : float
        Largest distance between the hand's and the target's grasp frame origins [m], > 0.
    tolerance_velocity : float
        Largest relative speed of the two bodies at the hand's grasp point [m/s], > 0.
    estimates : str
        What the controller knows of the target after capture (:data:`CAPTURE_ESTIMATES`):
        ``"unknown"`` (not told), ``"perturbed"`` or ``"true"``.
    hand_xyz, hand_rpy : tuple of float
        The hand's grasp frame in the end-effector frame [m], [rad] (the frame welded to the
        target's grasp frame; default the end-effector frame itself).
    detumble_rate : float
        The held target's angular rate relative to the bus [rad/s], > 0, below which (for
        good) the run counts it as detumbled (summary's ``detumble_time``; default
        :data:`DETUMBLE_RATE`, 0.1 deg/s).
    """

    tolerance_position: float
    tolerance_velocity: float
    estimates: str = "unknown"
    hand_xyz: tuple[float, ...] = (0.0, 0.0, 0.0)
    hand_rpy: tuple[float, ...] = (0.0, 0.0, 0.0)
    detumble_rate: float = DETUMBLE_RATE


@dataclass(frozen=True)
class ApproachSpec:
    """``[approach]``: the end-effector reference goes, over ``time`` seconds, from the
    ``[reference]``'s to the target's grasp frame, predicted from the target's measured state
    (a sensor with noise and delay: what the controller sees, never the plant;
    docs/capture.md, "The approach").

    Attributes
    ----------
    time : float
        The blend's duration [s], > 0 (a quintic from the ``[reference]`` to the grasp frame).
    seed : int
        Seed of the target sensor's noise.
    delay : int
        The target sensor's delay [control periods], >= 0 (compensated by the prediction).
    noise : tuple of float
        Standard deviations of the target sensor's noise, in :data:`APPROACH_NOISE_KEYS`
        order: position [m], attitude [rad] (a rotation vector), CoM velocity [m/s], body
        angular velocity [rad/s].
    """

    time: float
    seed: int = 0
    delay: int = 0
    noise: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TargetSpec:
    """``[target]``: a box, or a one-body URDF, tumbling torque-free (free-flyer robots only).

    Attributes
    ----------
    size : tuple of float or None
        Edges (a, b, c) of a box centred on the target frame [m] (None with ``urdf``).
    mass : float or None
        [kg] (None with ``urdf``).
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
    capture : CaptureSpec or None
        The file's ``[capture]`` table (None: the robot never grasps the target).
    approach : ApproachSpec or None
        The file's ``[approach]`` table (None: the reference is the ``[reference]``'s).
    urdf : str or None
        A one-body URDF whose link's inertial is the target (instead of a box): its mass, CoM
        and inertia; the link frame is the target frame.
    relative_to : str or None
        The folder a relative ``urdf`` path is relative to (the scenario file's).
    """

    size: tuple[float, ...] | None
    mass: float | None
    position: tuple[float, ...]
    shape: str = "box"
    inertia: tuple[float, ...] | None = None
    attitude_rpy: tuple[float, ...] = (0.0, 0.0, 0.0)
    velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    origin: str = "world"
    grasp_xyz: tuple[float, ...] = (0.0, 0.0, 0.0)
    grasp_rpy: tuple[float, ...] = (0.0, 0.0, 0.0)
    capture: CaptureSpec | None = None
    approach: ApproachSpec | None = None
    urdf: str | None = None
    relative_to: str | None = None
