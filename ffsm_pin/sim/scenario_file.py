"""Deprecated location of :mod:`ffsm_pin.scenario.file` (an alias for one release)."""

import sys
import warnings

from ..scenario import file as _moved

warnings.warn(
    "ffsm_pin.sim.scenario_file moved to ffsm_pin.scenario.file; "
    "this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
