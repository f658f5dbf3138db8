"""Spatial free-floating manipulators (m2 = m3 = 3): loader, Pinocchio state, barycentric model.

* :mod:`.mrp`: modified Rodrigues parameters (attitudes of the base and the end effector);
* :mod:`.robot`: :func:`load_spatial_robot` (free-flyer root, example-robot-data arms,
  satellite body, locked joints) and :class:`SpatialGeometry`;
* :mod:`.state`: :class:`SpatialState`, the reduced quantities from Pinocchio's algorithms;
* :mod:`.barycentric`: :class:`SpatialBarycentricModel`, theta_z, theta_d, theta_b and regressors.

Velocities (docs/spatial.md section 1): w = (w_b, dq_m) with w_b the base angular velocity in
the *inertial* frame.
"""

from .robot import Satellite, SpatialGeometry, SpatialRobot, load_spatial_robot

__all__ = ["Satellite", "SpatialGeometry", "SpatialRobot", "load_spatial_robot"]
