"""Scenarios: everything one run needs, as frozen dataclasses, and their TOML files.

Layers inside (imports run downwards only):

* :mod:`~ffsm_pin.scenario.trajectory`: references from data (samples through a spline,
  rest-to-rest waypoints) as one piecewise-polynomial table;
* :mod:`~ffsm_pin.scenario.devices`: the ``[actuators]`` and ``[sensors]`` options;
* :mod:`~ffsm_pin.scenario.target_spec`: the ``[target]`` body (:class:`TargetSpec`) and
  ``[capture]`` (:class:`CaptureSpec`);
* :mod:`~ffsm_pin.scenario.spec`: the scenario's dataclasses (:class:`Scenario`, its robot,
  initial condition, reference, controller and performance specification) with their
  defaults (the lu-jia controller's own parameters are declared by it,
  :mod:`ffsm_pin.control.lu_jia_params`);
* :mod:`~ffsm_pin.scenario.values`, :mod:`~ffsm_pin.scenario.sections`,
  :mod:`~ffsm_pin.scenario.schema`: the scenario file's pydantic models (value types, one model
  per section, the whole file), which validate a file once and turn the first problem into one
  ``ScenarioError`` line naming its TOML key; they read their defaults from the dataclasses;
* :mod:`~ffsm_pin.scenario.reference_csv`: an end-effector reference from a CSV file;
* :mod:`~ffsm_pin.scenario.builder`: a validated document -> the dataclasses;
* :mod:`~ffsm_pin.scenario.writer`: a scenario -> its TOML file (:func:`scenario_to_toml`);
* :mod:`~ffsm_pin.scenario.check`: a scenario built in Python through the same models
  (:func:`check_scenario`);
* :mod:`~ffsm_pin.scenario.file`: TOML files read and the built-in scenarios (the paper's
  cases and the spatial cases, shipped in ``ffsm_pin/scenario/builtin/``).

The file format is documented in ``docs/cli.md``; the simulation that runs a scenario is
:mod:`ffsm_pin.sim`.
"""

from __future__ import annotations

from .check import check_scenario, scenario_document
from .devices import ActuatorSpec, SensorSpec
from .file import (
    BUILTIN,
    builtin_path,
    builtin_scenario,
    load_any,
    load_scenario,
    scenario_from_dict,
    scenario_from_toml,
)
from .reference_csv import read_reference_csv
from .spec import (
    ComponentReference,
    ControllerSpec,
    Estimates,
    Harmonic,
    InitialCondition,
    Performance,
    Reference,
    RobotSpec,
    Scenario,
)
from .target_spec import CaptureSpec, TargetSpec
from .trajectory import ReferenceData
from .writer import scenario_to_toml

__all__ = [
    "BUILTIN",
    "ActuatorSpec",
    "CaptureSpec",
    "ComponentReference",
    "ControllerSpec",
    "Estimates",
    "Harmonic",
    "InitialCondition",
    "Performance",
    "Reference",
    "ReferenceData",
    "RobotSpec",
    "Scenario",
    "SensorSpec",
    "TargetSpec",
    "builtin_path",
    "builtin_scenario",
    "check_scenario",
    "load_any",
    "load_scenario",
    "read_reference_csv",
    "scenario_from_dict",
    "scenario_document",
    "scenario_from_toml",
    "scenario_to_toml",
]
