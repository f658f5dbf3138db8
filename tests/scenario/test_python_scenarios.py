"""A scenario built in Python is checked by the same schema as a file (one validator): what a
file may not say, a Python-built scenario may not either, with the same one-line message naming
the key (ffsm_pin.scenario.file.check_scenario, called by prepare)."""

from __future__ import annotations

import dataclasses
import re

import pytest

from ffsm_pin.control.funnel import FunnelParams
from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario import builtin_scenario, scenario_to_toml
from ffsm_pin.scenario.check import check_scenario, scenario_document
from ffsm_pin.scenario.file import scenario_from_dict
from ffsm_pin.scenario.spec import Estimates
from ffsm_pin.sim.run import prepare


def _planar_with(**changes):
    sc = builtin_scenario("case1")
    ctrl = changes.pop("controller", {})
    lu_jia = dataclasses.replace(sc.controller.lu_jia, **changes.pop("lu_jia", {}))
    ref = changes.pop("reference", {})
    ini = changes.pop("initial", {})
    perf = changes.pop("performance", {})
    return dataclasses.replace(
        sc,
        controller=dataclasses.replace(sc.controller, lu_jia=lu_jia, **ctrl),
        reference=dataclasses.replace(sc.reference, **ref),
        initial=dataclasses.replace(sc.initial, **ini),
        performance=dataclasses.replace(sc.performance, **perf),
        **changes,
    )


BAD = {  # what a Python user can build but a file may not say -> start of the message
    "funnel size": (
        {"performance": {"funnel_b": FunnelParams((1.0, 1.0), (0.1, 0.1), (0.2,) * 2, (0.8,) * 2)}},
        "controller.funnel.rho_b0",
    ),
    "base attitude size": (
        {"reference": {"base_attitude": (0.0, 0.0, 0.0)}},
        "reference.base_attitude",
    ),
    "reference size": (
        {"reference": {"ee": builtin_scenario("case1").reference.ee[:2]}},
        "reference.ee",
    ),
    "base twist size": (
        {"initial": {"base_twist": (0.0, 0.0, 0.0, 0.0)}},
        "initial.base_twist",
    ),
    # the rules the dataclasses checked themselves before: now the schema's alone
    "task": ({"reference": {"task": "bogus"}}, "reference.task = 'bogus' unknown"),
    "origin": ({"reference": {"origin": "bogus"}}, "reference.origin = 'bogus' unknown"),
    "scheme": ({"lu_jia": {"scheme": "bogus"}}, "controller.scheme = 'bogus' unknown"),
    "threshold": ({"performance": {"singularity_threshold": -1.0}},
                  "controller.singularity.threshold = -1.0: must be > 0"),
    "max damped time": ({"lu_jia": {"max_damped_time": 0.0}},
                        "controller.singularity.max_damped_time = 0.0: must be > 0"),
    "empty type": ({"controller": {"type": ""}}, "controller.type"),
    "type not a string": ({"controller": {"type": 3}}, "controller.type: expected a string"),
    "estimates kind": (
        {"controller": {"estimates": Estimates(initial="bogus")}},
        "controller.estimates.initial = 'bogus' unknown",
    ),
    "explicit without thetas": (
        {"controller": {"estimates": Estimates(initial="explicit")}},
        "controller.estimates: initial = 'explicit' needs",
    ),
    "spread": ({"controller": {"estimates": Estimates(spread=1.0)}}, "controller.estimates.spread"),
    "seed": ({"controller": {"estimates": Estimates(seed="x")}}, "controller.estimates.seed"),
    "integrator": ({"integrator": "euler"}, "sim.integrator = 'euler' unknown"),
    "substeps 0": ({"substeps": 0}, "sim.substeps = 0: must be >= 1"),
    "substeps not an integer": ({"substeps": 1.5}, "sim.substeps: expected an integer"),
    "substeps a bool": ({"substeps": True}, "sim.substeps: expected an integer"),
    "substeps a string": ({"substeps": "2"}, "sim.substeps: expected an integer"),
    "negative dt": ({"dt": -1e-3}, "sim.dt = -0.001: must be > 0"),
    "dt not a number": ({"dt": float("nan")}, "sim.dt = nan: must be finite"),
    "infinite duration": ({"duration": float("inf")}, "sim.duration = inf: must be finite"),
    "dt beyond duration": ({"dt": 2.0, "duration": 1.0}, "sim.dt = 2.0 is longer than"),
}  # fmt: skip


@pytest.mark.parametrize("what", list(BAD))
def test_a_python_scenario_gets_the_files_message(what):
    changes, key = BAD[what]
    sc = _planar_with(**changes)
    with pytest.raises(ScenarioError) as from_python:
        check_scenario(sc)
    with pytest.raises(ScenarioError) as from_file:  # the same scenario written as a file
        scenario_from_dict(scenario_document(sc))
    assert str(from_python.value) == str(from_file.value)
    assert str(from_python.value).startswith(key), str(from_python.value)
    with pytest.raises(ScenarioError, match=re.escape(key)):
        prepare(sc)  # a run refuses it before loading anything


@pytest.mark.parametrize("name", ["case1", "spatial", "spatial-pose", "planar5"])
def test_valid_scenarios_pass_and_their_document_is_their_file(name):
    sc = builtin_scenario(name)
    check_scenario(sc)  # no error
    again = scenario_from_dict(scenario_document(sc))
    assert scenario_to_toml(again) == scenario_to_toml(sc)


def test_controller_params_are_the_controllers_own():
    """[controller.params] is a free table for the controller: any Python value a user hands to
    their own controller passes the check (the schema does not read it)."""
    sc = _planar_with(controller={"params": {"model": object(), "gain": 2}})
    check_scenario(sc)
