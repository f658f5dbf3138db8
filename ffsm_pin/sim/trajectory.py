"""Deprecated location of :mod:`ffsm_pin.scenario.trajectory` (an alias for one release)."""

import sys
import warnings

from ..scenario import trajectory as _moved

warnings.warn(
    "ffsm_pin.sim.trajectory moved to ffsm_pin.scenario.trajectory; "
    "this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
