"""Deprecated location of :mod:`ffsm_pin.model.spatial` (an alias for one release)."""

import sys
import warnings

from ..model import spatial as _moved

warnings.warn(
    "ffsm_pin.spatial.barycentric moved to ffsm_pin.model.spatial; "
    "this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
