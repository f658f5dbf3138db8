"""Robots: URDF -> Pinocchio model on a floating root -> a validated :class:`Robot`.

* :mod:`.urdf`: where a robot description is found (paths, shipped robots, example-robot-data)
  and the documented repairs of its XML;
* :mod:`.roots`: the root-joint table, everything that differs between a planar and a
  free-flying base;
* :mod:`.geometry`: the chain's geometry read from Pinocchio, and its checks;
* :mod:`.satellite`: a satellite body added under an arm-only URDF;
* :mod:`.payload`: a payload held by the end effector;
* :mod:`.robot`: the :class:`Robot` class; :mod:`.loader`: :func:`load_robot`.

``FreeFloatingRobot`` and ``SpatialRobot`` are the names of the planar and spatial robot
classes of 0.1.0; both are now :class:`Robot` (``robot.base`` tells them apart).
"""

from .geometry import PlanarGeometry, SpatialGeometry, check_inertia
from .loader import load_robot, load_spatial_robot
from .payload import Payload
from .robot import Robot
from .roots import ROOTS, SUPPORTED_BASES, RootJoint
from .satellite import Satellite
from .urdf import (
    EXAMPLE_ROBOTS,
    UrdfWarning,
    add_missing_limits,
    example_robot_data_dir,
    resolve_source,
    resolve_urdf,
    shipped_urdfs,
    urdf_dir,
)

FreeFloatingRobot = Robot  # 0.1.0 name of the planar robot class
SpatialRobot = Robot  # 0.1.0 name of the spatial robot class

__all__ = [
    "EXAMPLE_ROBOTS",
    "ROOTS",
    "SUPPORTED_BASES",
    "FreeFloatingRobot",
    "Payload",
    "PlanarGeometry",
    "Robot",
    "RootJoint",
    "Satellite",
    "SpatialGeometry",
    "SpatialRobot",
    "UrdfWarning",
    "add_missing_limits",
    "check_inertia",
    "example_robot_data_dir",
    "load_robot",
    "load_spatial_robot",
    "resolve_source",
    "resolve_urdf",
    "shipped_urdfs",
    "urdf_dir",
]
