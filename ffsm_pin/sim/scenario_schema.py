"""Deprecated location of :mod:`ffsm_pin.scenario.schema` (an alias for one release)."""

import sys
import warnings

from ..scenario import schema as _moved

warnings.warn(
    "ffsm_pin.sim.scenario_schema moved to ffsm_pin.scenario.schema; "
    "this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = _moved
