"""A scenario file that leaves a key out gets the default a Python user gets from the
dataclasses: the defaults are held once, by the dataclasses (ffsm_pin.scenario.spec, devices,
ffsm_pin.robot.Satellite), and the file's schema reads them from there."""

from __future__ import annotations

import dataclasses

import pytest

from ffsm_pin.control.gains import Gains, SingularityPolicy
from ffsm_pin.control.lu_jia_params import LuJiaParams
from ffsm_pin.control.null_space import NullSpace
from ffsm_pin.robot import Satellite
from ffsm_pin.scenario import (
    ActuatorSpec,
    ControllerSpec,
    Estimates,
    Performance,
    Reference,
    RobotSpec,
    Scenario,
    SensorSpec,
    scenario_from_dict,
)

# the smallest files of each root: what has no default (the initial state, the reference)
MINIMAL = {
    "planar": {
        "initial": {"base_pose": [0.0, 0.0, 0.0], "joints": [0.3, 0.3, 0.3, 0.3],
                    "base_twist": [0.0, 0.0, 0.0]},
        "reference": {"ee": [{"c": 1.0}, {"c": 1.0}, {"c": 0.5}]},
    },
    "free-flyer": {
        "robot": {"urdf": "panda.urdf", "base": "free-flyer", "end_effector": "panda_hand",
                  "satellite": {}},
        "initial": {"base_pose": [0.0] * 6, "joints": [0.0] * 7, "base_twist": [0.0] * 6},
        "reference": {"task": "position", "ee": [{"c": 0.5}, {"c": 0.0}, {"c": 1.0}]},
        "controller": {"funnel": {"rho_b0": 1.0, "rho_binf": 0.1, "beta_b": 0.2, "sigma_b": 0.8,
                                  "rho_z0": 1.0, "rho_zinf": 0.1, "beta_z": 0.2,
                                  "sigma_z": 0.8}},
    },
}  # fmt: skip


def _defaults(cls: type, *skip: str) -> dict:
    """Field -> default of a dataclass, without the fields in ``skip``."""
    out = {}
    for f in dataclasses.fields(cls):
        if f.name in skip or (
            f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        ):
            continue
        out[f.name] = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    return out


def _fields(obj, names) -> dict:
    return {name: getattr(obj, name) for name in names}


@pytest.mark.parametrize("base", list(MINIMAL))
def test_a_minimal_file_gets_the_dataclass_defaults(base):
    sc = scenario_from_dict(MINIMAL[base])
    top = _defaults(Scenario, "name", "source", *(["performance"] if base != "planar" else []))
    assert _fields(sc, top) == top  # duration, dt, description, integrator, substeps, devices
    assert sc.actuators == ActuatorSpec() and sc.sensors == SensorSpec()
    robot = _defaults(
        RobotSpec,
        "relative_to",
        *(["urdf", "base", "end_effector", "satellite"] if base == "free-flyer" else []),
    )
    assert _fields(sc.robot, robot) == robot
    if base == "free-flyer":
        assert sc.robot.satellite == Satellite()  # an empty [robot.satellite] table
    ref = _defaults(
        Reference, "ee", "data", "base_attitude", *(["task"] if base != "planar" else [])
    )
    assert _fields(sc.reference, ref) == ref
    c = sc.controller
    ctrl = _defaults(ControllerSpec, "lu_jia")
    assert _fields(c, ctrl) == ctrl  # type, params, estimates
    assert c.estimates == Estimates()
    perf = _defaults(Performance, *(["funnel_b", "funnel_z"] if base != "planar" else []))
    assert _fields(sc.performance, perf) == perf  # the paper's funnels (planar), the threshold
    assert sc.performance.singularity_threshold == SingularityPolicy().threshold
    lu_jia = _defaults(LuJiaParams, "gains")  # scheme, null space, max_damped_time
    assert _fields(c.lu_jia, lu_jia) == lu_jia
    assert c.lu_jia.null_space == NullSpace()
    assert c.lu_jia.policy(sc.performance.singularity_threshold) == SingularityPolicy()
    # k_b and k_z are derived when omitted (docs/gains.md); the other gains are the dataclass's
    gains = _defaults(Gains, "k_b", "k_z")
    assert _fields(c.lu_jia.gains, gains) == gains


def test_every_default_of_the_python_api_is_a_valid_file_value():
    """The dataclass defaults written into a file load back unchanged (scenario_to_toml of a
    scenario built in Python with every default)."""
    from ffsm_pin.scenario import scenario_from_toml, scenario_to_toml

    sc = scenario_from_dict(MINIMAL["planar"])
    assert scenario_from_toml(scenario_to_toml(sc)) == dataclasses.replace(sc, name=sc.name)
