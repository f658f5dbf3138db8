"""Deprecated location: the spatial state is :class:`ffsm_pin.model.State` (one class for both
roots); kept as an alias for one release."""

import warnings

from ..model._state_spatial import reaction_torque  # noqa: F401
from ..model.state import State as SpatialState  # noqa: F401

warnings.warn(
    "ffsm_pin.spatial.state moved to ffsm_pin.model.state (SpatialState is now State); this "
    "alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
