"""Deprecated location of :mod:`ffsm_pin.model._spatial_kernels` (an alias for one release)."""

import sys
import warnings

from ..model import _spatial_kernels as _moved

warnings.warn(
    "ffsm_pin.spatial._kernels moved to ffsm_pin.model._spatial_kernels; "
    "this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
