"""The pydantic models of the scenario file: every kind of bad input is ONE line that starts
with the TOML key path (no pydantic dump, no URL), and valid scenarios survive
scenario_to_toml -> scenario_from_toml unchanged."""

from __future__ import annotations

import copy
import math
import sys

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffsm_pin._schema import key_path
from ffsm_pin.attitude import mrp
from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario.file import (
    BUILTIN,
    builtin_path,
    builtin_scenario,
    scenario_from_dict,
    scenario_from_toml,
)
from ffsm_pin.scenario.schema import ScenarioModel
from ffsm_pin.scenario.writer import scenario_to_toml

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def doc(name: str) -> dict:
    return tomllib.loads(builtin_path(name).read_text())


def edited(name: str, path: str, value) -> dict:
    """Built-in ``name`` as a dict with ``path`` ("a.b.c") set to value (None: deleted)."""
    d = doc(name)
    *parents, last = path.split(".")
    table = d
    for p in parents:
        table = table.setdefault(p, {})
    if value is None:
        del table[last]
    else:
        table[last] = value
    return d


def one_line(d: dict, *fragments: str) -> str:
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    msg = str(info.value)
    assert "\n" not in msg and "pydantic" not in msg.lower() and "http" not in msg, msg
    assert msg.startswith(fragments[0]), msg
    for f in fragments:
        assert f in msg, (f, msg)
    return msg


# name -> (built-in, dotted key to set, value (None: delete), fragments; the first is the path)
BAD = {
    "unknown section": ("case1", "controler", {"k_z": 1.0},
                        ("controler: unknown section at the top level",
                         "did you mean 'controller'?", "valid keys:", "'sim'")),
    "unknown key with hint": ("case1", "controller.estimates.sprad", 0.1,
                              ("controller.estimates.sprad: unknown key in [controller.estimates]",
                               "did you mean 'spread'?", "'theta_b'")),
    "unknown satellite key": ("spatial", "robot.satellite.mas", 300.0,
                              ("robot.satellite.mas", "did you mean 'mass'?", "'mount_rpy'")),
    "string for a number": ("case1", "controller.k_z", "0.04",
                            ("controller.k_z: expected a number", "'0.04' (string)")),
    "boolean for a number": ("case1", "controller.k_z", True, ("controller.k_z", "a number")),
    "number for an integer": ("case1", "controller.estimates.seed", 2.0,
                              ("controller.estimates.seed", "an integer")),
    "number for a string": ("case1", "controller.scheme", 3,
                            ("controller.scheme: expected a string", "3 (integer)")),
    "table for a number": ("case1", "sim.dt", {"x": 1}, ("sim.dt: expected a number",)),
    "non-finite": ("case1", "controller.k_b", math.inf, ("controller.k_b = inf", "finite")),
    "item of a vector": ("case1", "initial.joints", [0.1, "x", 0.2, 0.3],
                         ("initial.joints: expected a list of numbers",)),
    "wrong length": ("case1", "initial.base_twist", [0.0, 0.0],
                     ("initial.base_twist: 2 values, expected 3",)),
    "satellite vector length": ("spatial", "robot.satellite.size", [1.0, 1.0],
                                ("robot.satellite.size: 2 values, expected 3",)),
    "out of range": ("case1", "controller.gamma_1", -0.5,
                     ("controller.gamma_1 = -0.5: must be > 0",)),
    "integer out of range": ("case1", "sim.substeps", 0, ("sim.substeps = 0: must be >= 1",)),
    "half-open interval": ("case1", "controller.estimates.spread", 1.0,
                           ("controller.estimates.spread = 1.0: must be in [0, 1)",)),
    "bad choice": ("case1", "reference.task", "poses",
                   ("reference.task = 'poses' unknown", "did you mean 'pose'?",
                    "valid choices: 'pose', 'position'")),
    "bad null-space objective": ("case1", "controller.null_space.objective", "manip",
                                 ("controller.null_space.objective", "valid choices:",
                                  "'joint-centering'")),
    "estimate kind": ("case1", "controller.estimates.initial", "truth",
                      ("controller.estimates.initial = 'truth' unknown",
                       "did you mean 'true'?", "'explicit'")),
    "MRP beyond 1 in base_pose": ("spatial", "initial.base_pose", [0, 0, 0, 0.8, 0.8, 0.0],
                                  ("initial.base_pose[3:6]: MRP", "|s| = 1.131 > 1", "shadow")),
    "MRP beyond 1 in the reference": ("spatial", "reference.base_attitude", [0.0, 0.0, -1.2],
                                      ("reference.base_attitude: MRP", "|s| = 1.2 > 1")),
    "funnel length for the task": ("spatial", "controller.funnel.rho_z0", [0.2, 0.2],
                                   ("controller.funnel.rho_z0: 2 values, expected 3",
                                    "end-effector task")),
    "funnel element": ("spatial", "controller.funnel.sigma_b", [0.8, 0.8, 1.2],
                       ("controller.funnel.sigma_b[2] = 1.2: must be in (0, 1]",)),
    "funnel scalar broadcast": ("case1", "controller.funnel.beta_z", 0.0,
                                ("controller.funnel.beta_z = 0.0: must be > 0",)),
    "quaternion not unit": ("spatial", "initial.base_attitude_quaternion", [0, 0, 0.5, 0.5],
                            ("initial.base_attitude_quaternion: (x, y, z, w) must have unit "
                             "norm, got 0.707107",)),
    "attitude for a planar base": ("case1", "initial.base_attitude_rpy", [0.0, 0.0, 0.1],
                                   ("initial.base_attitude_rpy: only for base = 'free-flyer'",)),
    "spatial rate as a number": ("spatial", "initial.base_rate", 0.1,
                                 ("initial.base_rate: expected 3 numbers",)),
    "satellite on a planar base": ("case1", "robot.satellite", {"mass": 100.0},
                                   ("robot.locked_joints and [robot.satellite] apply only",)),
    "center without centering": ("case1", "controller.null_space.center", [0.0] * 4,
                                 ("controller.null_space.center: only used with objective = "
                                  "'joint-centering'",)),
    "missing required key": ("case1", "initial.joints", None, ("initial.joints: missing",)),
    "section not a table": ("case1", "controller.funnel", [1.0],
                            ("controller.funnel: expected a table [controller.funnel]",)),
}  # fmt: skip


@pytest.mark.parametrize("what", list(BAD))
def test_each_error_is_one_line_with_the_key_path_first(what):
    name, path, value, fragments = BAD[what]
    d = edited(name, path, value)
    if what == "quaternion not unit":  # position only in base_pose then
        d["initial"]["base_pose"] = d["initial"]["base_pose"][:3]
    if what == "spatial rate as a number":
        d["initial"].pop("base_twist", None)
        d["initial"]["com_velocity"] = [0.0, 0.0, 0.0]
    one_line(d, *fragments)


def test_several_errors_report_the_first_and_count_the_rest():
    d = doc("case1")
    d["controller"]["k_z"] = "fast"
    d["sim"]["dt"] = "small"
    msg = one_line(d, "controller.k_z", "(and 1 more)")
    assert "sim.dt" not in msg


def test_unknown_keys_come_before_other_errors():
    d = doc("case1")
    d["controller"]["k_z"] = "fast"
    d["sim"]["substep"] = 2
    one_line(d, "sim.substep: unknown key", "did you mean 'substeps'?")


def test_key_path_of_a_pydantic_location():
    loc = ("controller", "funnel", "rho_b0", "<list>", 0)  # "<list>": the union member's tag
    assert key_path(loc) == "controller.funnel.rho_b0[0]"
    assert key_path(("reference", "ee", 1, "cos", 0, 1)) == "reference.ee[1].cos[0][1]"


def test_models_forbid_unknown_keys_everywhere():
    """Every table of the file is a model with extra = "forbid" (no silently ignored key)."""
    seen, todo = set(), [ScenarioModel]
    while todo:
        model = todo.pop()
        if model in seen:
            continue
        seen.add(model)
        assert model.model_config.get("extra") == "forbid", model
        assert model.model_config.get("strict") is True, model
        for field in model.model_fields.values():
            for sub in _models(field.annotation):
                todo.append(sub)
    assert len(seen) >= 12  # scenario, robot, satellite, initial, reference, ee, controller, ...


def _models(annotation):
    from pydantic import BaseModel

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        yield annotation
    for arg in getattr(annotation, "__args__", ()):
        yield from _models(arg)


@pytest.mark.parametrize("kind", ["rpy", "quaternion"])
def test_attitude_alternatives_give_the_rotation(kind):
    """rpy / quaternion become the MRP of the same rotation (checked with Pinocchio)."""
    R = pin.rpy.rpyToMatrix(0.3, -0.2, 0.25)
    d = doc("spatial")
    d["initial"]["base_pose"] = [0.1, 0.2, 0.3]
    if kind == "rpy":
        d["initial"]["base_attitude_rpy"] = [0.3, -0.2, 0.25]
    else:
        d["initial"]["base_attitude_quaternion"] = pin.Quaternion(R).coeffs().tolist()
    pose = scenario_from_dict(d).initial.base_pose
    assert pose[:3] == (0.1, 0.2, 0.3)
    np.testing.assert_allclose(mrp.to_rotation(np.array(pose[3:])), R, atol=1e-12)
    assert np.linalg.norm(pose[3:]) <= 1.0


@pytest.mark.parametrize("name", list(BUILTIN))
def test_builtin_toml_is_a_fixed_point(name):
    """Written and read back: the same Scenario and byte-identical text again."""
    sc = builtin_scenario(name)
    text = scenario_to_toml(sc)
    again = scenario_from_toml(text)
    assert scenario_to_toml(again) == text
    for field in ("robot", "initial", "reference", "controller", "duration", "dt", "substeps"):
        if field != "robot":
            assert getattr(again, field) == getattr(sc, field), field
    assert again.robot.satellite == sc.robot.satellite
    assert again.robot.locked_joints == sc.robot.locked_joints


# ------------------------------------------------------------------------------ round trip
positive = st.floats(1e-3, 1e3, allow_nan=False)
finite = st.floats(-1e3, 1e3, allow_nan=False)


@st.composite
def perturbed(draw):
    """A built-in with its numbers redrawn inside their valid ranges."""
    name = draw(st.sampled_from(sorted(BUILTIN)))
    d = copy.deepcopy(doc(name))
    c = d.setdefault("controller", {})
    for k in ("k_b", "k_z", "k_de", "k_d", "gamma_1", "gamma_2", "gamma_3"):
        if draw(st.booleans()):
            c[k] = draw(positive)
    est = c.setdefault("estimates", {})
    if est.get("initial", "paper") in ("perturbed", "paper"):
        est["spread"] = draw(st.floats(0.0, 0.99))
        est["seed"] = draw(st.integers(0, 2**31))
    f = c.setdefault("funnel", {})
    sc = builtin_scenario(name)
    for tag, params in (("b", sc.performance.funnel_b), ("z", sc.performance.funnel_z)):
        n = params.size
        rho0 = draw(st.lists(st.floats(0.01, 10.0), min_size=n, max_size=n))
        frac = draw(st.lists(st.floats(0.01, 0.99), min_size=n, max_size=n))
        f[f"rho_{tag}0"] = rho0
        f[f"rho_{tag}inf"] = [r * x for r, x in zip(rho0, frac, strict=True)]
        f[f"beta_{tag}"] = draw(st.one_of(positive, st.lists(positive, min_size=n, max_size=n)))
        f[f"sigma_{tag}"] = draw(st.lists(st.floats(0.01, 1.0), min_size=n, max_size=n))
    for entry in d["reference"]["ee"]:
        entry["c"] = draw(finite)
        entry["sin"] = draw(st.lists(st.tuples(finite, positive).map(list), max_size=2))
    ini = d["initial"]
    ini["joints"] = draw(st.lists(finite, min_size=len(ini["joints"]), max_size=len(ini["joints"])))
    ini.pop("joint_rates", None)
    sim = d.setdefault("sim", {})
    sim["duration"] = draw(st.floats(1.0, 100.0))
    sim["dt"] = draw(st.floats(1e-4, 1e-2))
    sim["substeps"] = draw(st.integers(1, 8))
    sim["integrator"] = draw(st.sampled_from(["semi-implicit", "rk4"]))
    return d


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(perturbed())
def test_round_trip_of_perturbed_builtins(d):
    sc = scenario_from_dict(d)
    again = scenario_from_toml(scenario_to_toml(sc))
    assert again == sc
