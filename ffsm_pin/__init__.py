"""ffsm-pin: free-floating space manipulators on Pinocchio.

Layers, from the bottom up (imports run downwards only):

* :mod:`ffsm_pin.robot` loads and validates a robot from URDF on a planar or free-flyer root;
* :mod:`ffsm_pin.attitude` holds the attitude representations (MRPs);
* :mod:`ffsm_pin.model` is the paper's reduced model: Pinocchio's reduced quantities for a state
  (:class:`State`) and the barycentric parameterisation (:func:`make_model`);
* :mod:`ffsm_pin.control` is the adaptive prescribed-performance controller of Lu & Jia (2019);
* :mod:`ffsm_pin.scenario` holds what a run needs (dataclasses, the scenario file and its
  validation, the built-in scenarios);
* :mod:`ffsm_pin.sim` is the momentum-exact plant, runs, figures and replay;
* :mod:`ffsm_pin.sweep` runs campaigns of many scenarios on Dask.

The names a user needs are importable from here: :func:`load_robot`, :class:`Robot`,
:class:`State`, :func:`make_model`, :class:`Scenario`, :func:`load_scenario`,
:func:`builtin_scenario`, :func:`prepare`, :func:`simulate` and :class:`FfsmError`.
"""

from __future__ import annotations

from importlib import import_module

from . import _numba_cache  # noqa: F401 - first: numba settings before numba loads
from .errors import FfsmError
from .model import State, make_model
from .robot import FreeFloatingRobot, Robot, load_robot, shipped_urdfs

__version__ = "0.2.0"

# the simulation layer is imported on first use, so that `import ffsm_pin` stays light
_LAZY = {
    "Scenario": "ffsm_pin.scenario.spec",
    "load_scenario": "ffsm_pin.scenario.file",
    "builtin_scenario": "ffsm_pin.scenario.file",
    "prepare": "ffsm_pin.sim.run",
    "simulate": "ffsm_pin.sim.run",
}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'ffsm_pin' has no attribute {name!r}")


__all__ = [
    "FfsmError",
    "FreeFloatingRobot",
    "Robot",
    "Scenario",
    "State",
    "builtin_scenario",
    "load_robot",
    "load_scenario",
    "make_model",
    "prepare",
    "shipped_urdfs",
    "simulate",
]
