"""Deprecated location of :mod:`ffsm_pin.model.interface` (an alias for one release)."""

import sys
import warnings

from .model import interface as _moved

warnings.warn(
    "ffsm_pin.reduced_model moved to ffsm_pin.model.interface; this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
