"""Deprecated location: the planar state is :class:`ffsm_pin.model.State` (one class for both
roots); kept as an alias for one release."""

import warnings

from .model._state_planar import base_twist_to_local, base_twist_to_world  # noqa: F401
from .model.state import State as FloatingBaseState  # noqa: F401

warnings.warn(
    "ffsm_pin.state moved to ffsm_pin.model.state (FloatingBaseState is now State); this alias "
    "goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
