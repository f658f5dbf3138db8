"""Deprecated location: the spatial loader is now :func:`ffsm_pin.robot.load_robot` with
``base="free-flyer"``; kept as an alias for one release."""

from ..robot import (  # noqa: F401
    EXAMPLE_ROBOTS,
    Satellite,
    SpatialGeometry,
    SpatialRobot,
    check_inertia,
    example_robot_data_dir,
    load_spatial_robot,
)
from ..robot import resolve_source as resolve_spatial_urdf  # noqa: F401
from ..robot.urdf import ERD_PREFIX  # noqa: F401
