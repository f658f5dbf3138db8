"""Deprecated location of :mod:`ffsm_pin.model.planar` (an alias for one release)."""

import sys
import warnings

from .model import planar as _moved

warnings.warn(
    "ffsm_pin.barycentric moved to ffsm_pin.model.planar; this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
