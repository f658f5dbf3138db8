"""The paper's reduced model: Pinocchio's reduced quantities and their barycentric
parameterisation, planar and spatial side by side.

* :mod:`.interface`: :class:`ReducedModel`, the protocol both barycentric models follow (the
  controller, plant and recorder are written against it);
* :mod:`.state`: :class:`State`, the reduced quantities (M, C w, H_bb, H_bm, J_b, J_m, momenta)
  of one plant state from Pinocchio, for either root;
* :mod:`.planar`: :class:`BarycentricModel` (m2 = 2, m3 = 1), theta_z, theta_d, theta_b and
  their regressors;
* :mod:`.spatial`: :class:`SpatialBarycentricModel` (m2 = m3 = 3, MRP attitudes), with its
  parameter layout (:mod:`._spatial_layout`), numpy reference (:mod:`._spatial_reference`),
  controller terms (:mod:`._spatial_terms`) and compiled kernels
  (:mod:`._spatial_kinematics_kernels`, :mod:`._spatial_mass_kernels`,
  :mod:`._spatial_velocity_kernels`).

:func:`make_model` builds the barycentric model that fits a robot's root joint.
"""

from __future__ import annotations

from ..robot import Robot
from .interface import ReducedModel
from .planar import BarycentricModel
from .spatial import SpatialBarycentricModel
from .state import State

#: barycentric model class by root joint
MODELS: dict[str, type] = {"planar": BarycentricModel, "free-flyer": SpatialBarycentricModel}


def make_model(robot: Robot, **options) -> ReducedModel:
    """The barycentric model of ``robot`` with its true parameters (planar or spatial, by
    ``robot.base``); ``options`` go to the model class (e.g. ``backend`` for spatial)."""
    return MODELS[robot.base](robot.geometry, **options)


__all__ = [
    "MODELS",
    "BarycentricModel",
    "ReducedModel",
    "SpatialBarycentricModel",
    "State",
    "make_model",
]
