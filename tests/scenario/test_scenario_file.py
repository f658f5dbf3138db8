"""Scenario files: the built-in cases load, bad input is refused naming the TOML key."""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import pytest

from ffsm_pin import paper
from ffsm_pin.errors import FfsmError, ScenarioError
from ffsm_pin.robot import load_robot, urdf_dir
from ffsm_pin.scenario.file import (
    BUILTIN,
    builtin_path,
    builtin_scenario,
    load_scenario,
    scenario_from_dict,
    scenario_from_toml,
)
from ffsm_pin.scenario.writer import scenario_to_toml

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

CASE1 = builtin_path("case1")


def case1_dict() -> dict:
    return tomllib.loads(CASE1.read_text())


def refused(d: dict, *fragments: str) -> str:
    """scenario_from_dict(d) raises ScenarioError whose message contains every fragment."""
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    msg = str(info.value)
    for f in fragments:
        assert f in msg, f"{f!r} not in {msg!r}"
    return msg


# ------------------------------------------------------------------------------ built-ins
# (not the free-flyer built-ins: the spatial ones, target-tumbling and capture)
PLANAR_BUILTIN = sorted(n for n in BUILTIN if builtin_scenario(n).robot.base == "planar")


@pytest.mark.parametrize("name", PLANAR_BUILTIN)
def test_every_builtin_loads(name):
    """(The spatial built-ins: tests/scenario/test_scenario_spatial.py.)"""
    sc = builtin_scenario(name)
    assert sc.name == name
    assert sc.duration == 30.0 and sc.dt == 1e-3
    assert sc.source == builtin_path(name)
    robot = load_robot(
        sc.robot.urdf, sc.robot.end_effector, base=sc.robot.base, relative_to=sc.robot.relative_to
    )
    assert len(sc.initial.joints) == robot.n_joints


def test_builtin_cases_follow_the_paper_and_model_md():
    c1, paper1 = builtin_scenario("case1"), builtin_scenario("case1-paper")
    assert c1.controller.scheme == "ppc"
    assert builtin_scenario("case2").controller.scheme == "no-ppc"
    assert builtin_scenario("case3").controller.scheme == "no-attitude"
    assert builtin_scenario("known-model").controller.scheme == "known-model"
    assert c1.initial.com_at_origin
    twist = (0.0969384842584869, 0.09656935470129872, -0.0037)  # reading A
    assert c1.initial.base_twist == pytest.approx(twist)
    assert c1.initial.base_pose[2] == paper.Q_B0
    assert c1.initial.joints == pytest.approx(paper.Q_M0)
    assert c1.controller.estimates.initial == "paper"
    assert c1.performance.funnel_b.rho0 == (1.0,)
    assert paper1.performance.funnel_b.rho0 == (0.4,)
    # everything else of case1-paper equals case1
    assert paper1.initial == c1.initial and paper1.reference == c1.reference
    assert paper1.performance.funnel_z == c1.performance.funnel_z
    assert paper1.controller.lu_jia.gains == c1.controller.lu_jia.gains
    # the reason for rho_b0 = 1.0 is written in the file
    text = CASE1.read_text()
    assert "docs/model.md section 7" in text and "12-13 s" in text and "18 %" in text
    # Eq. (80) at t = 0
    assert c1.reference.ee_pose(0.0) == pytest.approx([4.1, 2.3, 0.11])
    assert c1.reference.ee[0].cos[0].frequency == pytest.approx(math.pi / 9)


@pytest.mark.parametrize("name", PLANAR_BUILTIN)
def test_builtins_differ_from_case1_only_where_they_say(name):
    """(The spatial built-ins are compared with 'spatial' in test_scenario_spatial.py.)"""
    c1 = case1_dict()
    d = tomllib.loads(builtin_path(name).read_text())
    diffs = {
        f"{sec}.{k}"
        for sec in c1
        if isinstance(c1[sec], dict)
        for k in set(c1[sec]) | set(d[sec])
        if c1[sec].get(k) != d[sec].get(k)
    }
    expected = {
        "case1": set(),
        "case1-paper": {"controller.funnel"},
        "case2": {"controller.scheme"},
        "case3": {"controller.scheme"},
        "known-model": {"controller.scheme"},
        # another robot (5 links), its own initial state, a circle about its pose, 30 % error;
        # the paper's gains and funnels (docs/null_space.md)
        "planar5": {
            "robot.urdf",
            "initial.base_pose",
            "initial.joints",
            "initial.joint_rates",
            "initial.base_twist",
            "initial.com_velocity",
            "initial.angular_momentum",
            "reference.ee",
            "controller.estimates",
        },
    }[name]
    assert diffs == expected


def test_unknown_builtin_name_suggests():
    with pytest.raises(ScenarioError, match=r"did you mean 'case2'\?.*valid choices"):
        builtin_scenario("cas2")


def test_round_trip_through_toml():
    for name in BUILTIN:
        sc = builtin_scenario(name)
        again = scenario_from_toml(scenario_to_toml(sc))
        assert again.initial == sc.initial
        assert again.reference == sc.reference
        assert again.controller == sc.controller
        assert (again.duration, again.dt, again.name) == (sc.duration, sc.dt, sc.name)


def test_minimal_file_uses_defaults():
    d = {
        "initial": {"base_pose": [0, 0, 0.1], "joints": [1, -1, 1, -1], "base_twist": [0, 0, 0]},
        "reference": {"ee": [{"c": 3.9}, {"c": 2.3}, {"c": 0.0}]},
    }
    sc = scenario_from_dict(d)
    assert sc.initial.joint_rates == (0.0,) * 4
    assert sc.controller.scheme == "ppc" and sc.duration == 30.0 and sc.dt == 1e-3
    assert sc.robot.urdf == "ffsm_planar4.urdf"
    assert sc.reference.base_attitude == (0.0,)


def test_initial_velocity_by_momenta():
    d = case1_dict()
    del d["initial"]["base_twist"]
    d["initial"]["com_velocity"] = [0.0988, 0.0943]
    d["initial"]["angular_momentum"] = -1.6467
    sc = scenario_from_dict(d)
    assert sc.initial.angular_momentum == -1.6467 and sc.initial.base_twist is None
    d["initial"]["base_rate"] = -0.0037
    refused(d, "[initial]", "exactly one of base_rate or angular_momentum")


def test_scalar_funnel_entry_is_broadcast():
    d = case1_dict()
    d["controller"]["funnel"]["sigma_z"] = 0.5
    assert scenario_from_dict(d).performance.funnel_z.sigma == (0.5, 0.5, 0.5)


# ------------------------------------------------------------------------------ bad input
def test_misspelt_key_gets_a_hint_and_the_valid_keys():
    d = case1_dict()
    d["controller"]["k_zz"] = d["controller"].pop("k_z")
    msg = refused(d, "controller.k_zz", "did you mean 'k_z'?", "valid keys:", "'gamma_3'")
    assert msg.startswith("controller.k_zz")


def test_misspelt_section_gets_a_hint():
    d = case1_dict()
    d["simulation"] = d.pop("sim")
    refused(d, "simulation", "unknown section", "did you mean 'sim'?")
    d = case1_dict()
    d["controller"]["funel"] = d["controller"].pop("funnel")
    refused(d, "controller.funel", "did you mean 'funnel'?")


def test_misspelt_key_in_reference_entry():
    d = case1_dict()
    d["reference"]["ee"][1]["sine"] = d["reference"]["ee"][1].pop("sin")
    refused(d, "reference.ee[1].sine", "did you mean 'sin'?")


@pytest.mark.parametrize(
    ("section", "key", "value", "fragments"),
    [
        ("controller", "k_b", "fast", ("controller.k_b", "expected a number", "'fast'")),
        ("controller", "k_b", True, ("controller.k_b", "expected a number")),
        ("controller", "k_b", -1.0, ("controller.k_b", "must be > 0")),
        ("controller", "gamma_2", 0, ("controller.gamma_2", "must be > 0")),
        ("controller", "scheme", "ppcc", ("controller.scheme", "did you mean 'ppc'?", "'no-ppc'")),
        ("sim", "dt", 0.0, ("sim.dt", "must be > 0")),
        ("sim", "duration", -3, ("sim.duration", "must be > 0")),
        ("sim", "dt", "1e-3", ("sim.dt", "expected a number")),
        ("initial", "com_at_origin", 1, ("initial.com_at_origin", "true or false")),
        ("initial", "base_pose", [0, 0], ("initial.base_pose", "2 values, expected 3")),
        ("initial", "joints", [1, "a", 2, 3], ("initial.joints", "list of numbers")),
        ("initial", "base_twist", [0, 0], ("initial.base_twist", "expected 3")),
        ("robot", "base", "spherical", ("robot.base", "not supported", "'free-flyer'")),
        ("robot", "urdf", 3, ("robot.urdf", "expected a string")),
        ("reference", "base_attitude", [0, 0], ("reference.base_attitude", "expected 1")),
        ("reference", "ee", [{"c": 1}], ("reference.ee", "1 entries, expected 3")),
        ("reference", "ee", "x", ("reference.ee", "list of tables")),
    ],
)
def test_bad_values_name_the_key(section, key, value, fragments):
    d = case1_dict()
    d[section][key] = value
    msg = refused(d, *fragments)
    assert msg.startswith(fragments[0])


@pytest.mark.parametrize(
    ("key", "value", "fragments"),
    [
        ("sigma_b", [1.5], ("controller.funnel.sigma_b[0] = 1.5", "(0, 1]")),
        ("sigma_z", [0.8, 0.0, 0.8], ("controller.funnel.sigma_z[1] = 0.0", "(0, 1]")),
        ("rho_binf", [2.0], ("controller.funnel.rho_binf[0] = 2.0", "0 < rho_inf < rho_0 = 1.0")),
        ("rho_zinf", [0.08, -0.1, 0.05], ("controller.funnel.rho_zinf[1]", "0 < rho_inf")),
        ("rho_b0", [-1.0], ("controller.funnel.rho_b0[0] = -1.0", "must be > 0")),
        ("beta_z", [0.22, 0.22, 0.0], ("controller.funnel.beta_z[2] = 0.0", "must be > 0")),
        ("rho_z0", [1.0, 1.0], ("controller.funnel.rho_z0", "2 values, expected 3")),
        ("rho_b0", [1.0, 1.0], ("controller.funnel.rho_b0", "2 values, expected 1")),
        ("beta_b", ["x"], ("controller.funnel.beta_b", "list of numbers")),
        ("rho_z", [1.0], ("controller.funnel.rho_z", "did you mean 'rho_z0'?")),
    ],
)
def test_bad_funnels_name_the_key(key, value, fragments):
    d = case1_dict()
    d["controller"]["funnel"][key] = value
    refused(d, *fragments)


def test_bad_reference_terms():
    d = case1_dict()
    d["reference"]["ee"][0]["cos"] = [[0.1, 0.3, 7]]
    refused(d, "reference.ee[0].cos[0]", "[amplitude, angular_frequency]")
    d["reference"]["ee"][0]["cos"] = 0.1
    refused(d, "reference.ee[0].cos", "pairs")


def test_estimates():
    d = case1_dict()
    d["controller"]["estimates"] = {"initial": "explicit", "theta_z": [1.0] * 7}
    refused(d, "controller.estimates", "needs", "theta_d", "theta_b")
    d["controller"]["estimates"] = {"initial": "paper", "theta_z": [1.0] * 7}
    refused(d, "controller.estimates.theta_z", "only used with initial = 'explicit'")
    d["controller"]["estimates"] = {"initial": "table2"}
    refused(d, "controller.estimates.initial", "valid choices", "'perturbed'")
    d["controller"]["estimates"] = {"initial": "perturbed", "spread": 1.5}
    refused(d, "controller.estimates.spread", "[0, 1)")
    d["controller"]["estimates"] = {"initial": "perturbed", "seed": 1.5}
    refused(d, "controller.estimates.seed", "integer")
    d["controller"]["estimates"] = {"initial": "perturbed", "spread": 0.1, "seed": 3}
    est = scenario_from_dict(d).controller.estimates
    assert (est.initial, est.spread, est.seed) == ("perturbed", 0.1, 3)


def test_singularity_section():
    d = case1_dict()
    d["controller"]["singularity"] = {"threshold": 0.02, "max_damped_time": 1.0}
    sc = scenario_from_dict(d)
    assert sc.performance.singularity_threshold == 0.02  # the run's singularity measure
    assert sc.controller.lu_jia.max_damped_time == 1.0  # the lu-jia controller's own key
    pol = sc.controller.lu_jia.policy(sc.performance.singularity_threshold)
    assert (pol.threshold, pol.max_damped_time) == (0.02, 1.0)
    d["controller"]["singularity"] = {"threshold": -0.02}
    refused(d, "controller.singularity.threshold", "must be > 0")
    d["controller"]["singularity"] = {"treshold": 0.02}
    refused(d, "controller.singularity.treshold", "did you mean 'threshold'?")


def test_missing_required_keys():
    d = case1_dict()
    del d["initial"]["joints"]
    refused(d, "initial.joints", "missing")
    d = case1_dict()
    del d["reference"]
    refused(d, "reference.ee", "missing")
    d = case1_dict()
    del d["initial"]["base_twist"]
    refused(d, "[initial]", "base_twist")


def test_section_given_as_a_value():
    d = case1_dict()
    d["sim"] = 3
    refused(d, "sim", "expected a table")


def test_dt_longer_than_duration():
    d = case1_dict()
    d["sim"] = {"duration": 0.5, "dt": 1.0}
    refused(d, "sim.dt", "longer than sim.duration")


# ------------------------------------------------------------------------------ files
def test_missing_file_names_the_path(tmp_path):
    path = tmp_path / "nope.toml"
    with pytest.raises(ScenarioError, match=re.escape(str(path))):
        load_scenario(path)
    with pytest.raises(ScenarioError, match="folder"):
        load_scenario(tmp_path)


def test_bad_toml_gives_the_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n\n[robot\nurdf = "a.urdf"\n')
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert str(path) in msg and "invalid TOML" in msg and "line 3" in msg


def test_errors_from_a_file_name_the_file(tmp_path):
    path = tmp_path / "typo.toml"
    path.write_text(CASE1.read_text().replace("\nk_z =", "\nk_zz ="))
    with pytest.raises(ScenarioError, match=r"typo\.toml: controller\.k_zz.*did you mean 'k_z'"):
        load_scenario(path)


def test_all_errors_are_ffsm_errors():
    assert issubclass(ScenarioError, FfsmError) and issubclass(ScenarioError, ValueError)


def test_urdf_path_relative_to_the_scenario_file(tmp_path, monkeypatch):
    robots = tmp_path / "robots"
    robots.mkdir()
    (robots / "mine.urdf").write_text((urdf_dir() / "ffsm_planar4.urdf").read_text())
    sub = tmp_path / "scenarios"
    sub.mkdir()
    path = sub / "mine.toml"
    path.write_text(CASE1.read_text().replace('"ffsm_planar4.urdf"', '"../robots/mine.urdf"'))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the working directory must not matter
    sc = load_scenario(Path("..") / "scenarios" / "mine.toml")
    assert sc.name == "case1"
    assert Path(sc.robot.relative_to) == sub.resolve()
    robot = load_robot(sc.robot.urdf, sc.robot.end_effector, relative_to=sc.robot.relative_to)
    assert robot.urdf_path.resolve() == (robots / "mine.urdf").resolve()
    # the scenario as written into a run folder points at the same file from anywhere
    again = scenario_from_toml(scenario_to_toml(sc))
    assert Path(again.robot.urdf) == (robots / "mine.urdf").resolve()


def test_name_defaults_to_the_file_stem(tmp_path):
    path = tmp_path / "my_case.toml"
    path.write_text(CASE1.read_text().replace('name = "case1"', ""))
    assert load_scenario(path).name == "my_case"
