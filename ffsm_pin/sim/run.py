"""Closed-loop runs in two steps: :func:`prepare` a scenario, then :func:`simulate` it.

``prepare(scenario)`` (:mod:`ffsm_pin.sim.setup`) does every check that can fail *before*
simulating and raises :class:`~ffsm_pin.errors.FfsmError` subclasses. ``simulate(setup)``
(:mod:`ffsm_pin.sim.loop`) never raises on numerical trouble: a run that has to stop returns
``completed=False`` with the time and the reason, and everything recorded so far. This module
is where a user finds both.
"""

from __future__ import annotations

from .initial import initial_state
from .loop import simulate
from .measurement import Sensor
from .reach import ReachWarning
from .recording import recorder_shapes, recording_size
from .setup import Setup, prepare

__all__ = [
    "ReachWarning",
    "Sensor",
    "Setup",
    "initial_state",
    "prepare",
    "recorder_shapes",
    "recording_size",
    "simulate",
]
