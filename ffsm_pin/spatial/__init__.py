"""Deprecated package: its modules moved to :mod:`ffsm_pin.robot` (loading),
:mod:`ffsm_pin.attitude` (MRPs) and :mod:`ffsm_pin.model` (state, barycentric model, kernels).

The names below and the submodules ``mrp``, ``robot``, ``state``, ``barycentric`` keep working
for one release.
"""

from ..robot import Satellite, SpatialGeometry, SpatialRobot, load_spatial_robot

__all__ = ["Satellite", "SpatialGeometry", "SpatialRobot", "load_spatial_robot"]
