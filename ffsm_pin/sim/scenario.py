"""Deprecated location of :mod:`ffsm_pin.scenario.spec` (an alias for one release)."""

import sys
import warnings

from ..scenario import spec as _moved

warnings.warn(
    "ffsm_pin.sim.scenario moved to ffsm_pin.scenario.spec; this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
