"""Campaign files: validation (bad input = one ``error:`` line, exit 2, nothing written), case
expansion, values read back from the resolved scenario, built-in campaigns."""

from __future__ import annotations

import numpy as np
import pytest
from sweep_cases import SMALL

from ffsm_pin.scenario.file import builtin_scenario, scenario_from_toml
from ffsm_pin.sweep import cli
from ffsm_pin.sweep.campaign import (
    BUILTIN_CAMPAIGNS,
    CampaignError,
    campaign_from_toml,
    load_campaign,
)
from ffsm_pin.sweep.cases import expand
from ffsm_pin.sweep.check import check_cases

TWO = SMALL.replace('scenario = "case1"', 'scenario = ["case1", "planar5"]') + (
    '\n[campaign.set_for.planar5]\n"actuators.torque_limit" = 100.0\n'
)

# name -> (campaign text, fragment of the error line)
BAD = {
    "set_for an absent scenario": (
        TWO.replace("set_for.planar5", "set_for.case2"),
        "campaign.set_for.case2: not a scenario of this campaign; valid choices: 'case1', "
        "'planar5'",
    ),
    "set_for a key set for every case": (
        TWO + '"controller.estimates.initial" = "true"\n',
        "also set for every case",
    ),
    "a scenario twice": (
        SMALL.replace('scenario = "case1"', 'scenario = ["case1", "case1"]'),
        "'case1' appears twice",
    ),
    "unknown key path": (
        SMALL.replace("controller.estimates.spread", "controller.estimates.sprad"),
        "controller.estimates.sprad: unknown key",
    ),
    "unknown section in the scenario": (
        SMALL + '[[vary]]\nkey = "controler.k_z"\nvalues = [0.1]\n',
        "controler: unknown section",
    ),
    "empty values": (SMALL.replace("values = [0.1, 0.3]", "values = []"), "non-empty list"),
    "values not a list": (SMALL.replace("values = [0.1, 0.3]", "values = 0.1"), "non-empty list"),
    "wrong type of a value": (
        SMALL.replace("values = [0.1, 0.3]", 'values = [0.1, "big"]'),
        "controller.estimates.spread: expected a number",
    ),
    "wrong type of repeat": (SMALL.replace("repeat = 2", 'repeat = "2"'), "campaign.repeat"),
    "wrong type of seed": (SMALL.replace("seed = 11", "seed = 1.5"), "campaign.seed"),
    "unknown scenario": (
        SMALL.replace('scenario = "case1"', 'scenario = "case9"'),
        "'case9' is neither a built-in scenario",
    ),
    "duplicate vary keys": (
        SMALL + '[[vary]]\nkey = "controller.estimates.spread"\nvalues = [0.2]\n',
        "controller.estimates.spread: given twice",
    ),
    "key both set and varied": (
        SMALL.replace('"controller.estimates.initial"', '"controller.estimates.spread"'),
        "controller.estimates.spread: given twice",
    ),
    "duplicate values": (SMALL.replace("[0.1, 0.3]", "[0.1, 0.3, 0.1]"), "appears twice"),
    "duplicate TOML keys": (SMALL.replace("seed = 11", "seed = 11\nseed = 12"), "invalid TOML"),
    "repeat 0": (SMALL.replace("repeat = 2", "repeat = 0"), "campaign.repeat = 0: must be >= 1"),
    "repeat negative": (SMALL.replace("repeat = 2", "repeat = -3"), "must be >= 1"),
    "value the scenario rejects": (
        SMALL.replace("[0.1, 0.3]", "[0.1, 1.5]"),
        "controller.estimates.spread = 1.5: must be in [0, 1)",
    ),
    "value the run set-up rejects": (  # initial end-effector error (-0.23, 0.48) outside rho_z0
        SMALL + '[[vary]]\nkey = "controller.funnel.rho_z0"\nvalues = [0.3]\n',
        "is not strictly inside its funnel",
    ),
    "bad TOML": (SMALL.replace("[campaign.set]", "[campaign.set"), "invalid TOML"),
    "unknown campaign key": (SMALL.replace("seed = 11", "sed = 11"), "campaign.sed: unknown key"),
    "the seed key": (
        SMALL.replace('"controller.estimates.initial"', '"controller.estimates.seed"').replace(
            '= "perturbed"', "= 3"
        ),
        "set by the campaign",
    ),
    "unknown distribution": (
        SMALL + '[[sample]]\nkey = "controller.k_z"\ndistribution = "gauss"\nmean = 1\nstd = 1\n',
        "'gauss' unknown",
    ),
    "sampled value the scenario rejects": (
        SMALL
        + '[[sample]]\nkey = "controller.k_z"\ndistribution = "uniform"\nlow = -2\nhigh = -1\n',
        "controller.k_z = -",
    ),
}


@pytest.mark.parametrize("what", list(BAD))
def test_bad_campaign_is_one_error_line_exit_2_nothing_written(
    what, campaign_file, tmp_path, capsys
):
    text, fragment = BAD[what]
    path = campaign_file(text)
    out = tmp_path / "out"
    status = cli.main([str(path), "--out", str(out), "--workers", "1"])
    err = capsys.readouterr()
    assert status == 2, err.err
    lines = err.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in err.err and err.out == ""
    assert not out.exists()


def test_missing_campaign_names_the_builtins(tmp_path, capsys):
    status = cli.main(["robustness-case", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.splitlines()
    assert status == 2 and len(err) == 1 and "robustness-case1" in err[0]
    assert not (tmp_path / "o").exists()


def test_expansion(campaign_file):
    campaign = load_campaign(campaign_file(SMALL))
    cases = expand(campaign)
    assert len(cases) == campaign.n_cases == 1 + 2 * 2
    assert [c.index for c in cases] == list(range(5))
    # case 0: the scenario file as it is, with only duration and dt replaced
    nominal = builtin_scenario("case1")
    sc0 = cases[0].scenario
    assert cases[0].nominal and sc0.controller == nominal.controller
    assert (sc0.duration, sc0.dt) == (4.0, 0.002) and sc0.initial == nominal.initial
    # the grid: spreads outermost, repeats innermost, each case's own seed
    assert [c.point.get("controller.estimates.spread") for c in cases[1:]] == [0.1, 0.1, 0.3, 0.3]
    assert [c.repeat for c in cases[1:]] == [0, 1, 0, 1]
    assert len({c.estimates_seed for c in cases}) == 5
    for c in cases[1:]:
        sc = scenario_from_toml(c.scenario_toml)  # what the worker runs
        assert sc.controller.estimates.initial == "perturbed"
        assert sc.controller.estimates.spread == c.values["controller.estimates.spread"]
        assert sc.controller.estimates.seed == c.estimates_seed
    assert len({c.case_hash for c in cases}) == 5


def test_run_length_in_campaign_set_also_applies_to_the_nominal_case(campaign_file):
    """sim.duration / sim.dt in [campaign.set] are the run length and step of every case,
    the nominal one included (its other keys stay the scenario's)."""
    text = SMALL.replace("duration = 4.0\ndt = 0.002\n", "").replace(
        "[campaign.set]\n", '[campaign.set]\n"sim.duration" = 3.0\n"sim.dt" = 0.004\n'
    )
    cases = expand(load_campaign(campaign_file(text)))
    for c in cases:
        assert (c.scenario.duration, c.scenario.dt) == (3.0, 0.004)
    nominal = builtin_scenario("case1")
    assert cases[0].scenario.controller == nominal.controller  # "perturbed" not applied


def test_values_are_read_back_from_the_resolved_scenario(campaign_file):
    """An integer spread resolves to a float; a funnel entry given as one number resolves to
    one per component (recorded as that number when the column allows it); a sampled gain lies
    in its range."""
    text = SMALL.replace("[0.1, 0.3]", "[0, 0.3]") + (
        '[[vary]]\nkey = "controller.funnel.rho_b0"\nvalues = [1, 2.0]\n'
        '[[sample]]\nkey = "controller.k_z"\ndistribution = "log-uniform"\nlow = 0.01\nhigh = 0.1\n'
    )
    cases = expand(load_campaign(campaign_file(text)))
    assert len(cases) == 1 + 2 * 2 * 2
    for c in cases[1:]:
        sc = scenario_from_toml(c.scenario_toml)
        assert c.values["controller.estimates.spread"] == sc.controller.estimates.spread
        assert isinstance(c.values["controller.estimates.spread"], float)
        assert sc.performance.funnel_b.rho0 == (c.values["controller.funnel.rho_b0"],)
        k_z = c.values["controller.k_z"]
        assert k_z == sc.controller.lu_jia.gains.k_z and 0.01 <= k_z <= 0.1
    # the nominal case records what the scenario file itself uses
    assert cases[0].values["controller.k_z"] == 0.04
    assert cases[0].values["controller.funnel.rho_b0"] == 1.0
    # case 1's rho_z0 = [1.0, 1.0, 0.2] is a list: then the column holds lists for every case
    text = SMALL + '[[vary]]\nkey = "controller.funnel.rho_z0"\nvalues = [1.5]\n'
    cases = expand(load_campaign(campaign_file(text, "lists.toml")))
    assert cases[0].values["controller.funnel.rho_z0"] == [1.0, 1.0, 0.2]
    assert all(c.values["controller.funnel.rho_z0"] == [1.5] * 3 for c in cases[1:])


def test_sampled_values_are_seeded_and_spread(campaign_file):
    text = SMALL.replace("repeat = 2", "repeat = 200") + (
        '[[sample]]\nkey = "controller.k_b"\ndistribution = "normal"\nmean = 0.05\nstd = 0.005\n'
    )
    a = expand(load_campaign(campaign_file(text)))
    b = expand(load_campaign(campaign_file(text, "again.toml")))
    draws = [c.values["controller.k_b"] for c in a[1:]]
    assert draws == [c.values["controller.k_b"] for c in b[1:]]
    # 400 normal draws: mean within 4 standard errors, sd within 15 %
    import numpy as np

    assert abs(np.mean(draws) - 0.05) < 4 * 0.005 / np.sqrt(400)
    assert abs(np.std(draws) / 0.005 - 1) < 0.15


def test_case_hash_changes_with_content(campaign_file):
    cases = expand(load_campaign(campaign_file(SMALL)))
    other = expand(load_campaign(campaign_file(SMALL.replace("seed = 11", "seed = 12"), "b.toml")))
    assert cases[0].case_hash == other[0].case_hash  # nominal does not use the root seed
    assert not {c.case_hash for c in cases[1:]} & {c.case_hash for c in other[1:]}


def test_builtin_robustness_campaign_is_valid():
    campaign = load_campaign("robustness-case1")
    cases = expand(campaign)
    assert len(cases) == 1 + 6 * 50 and campaign.duration == 30.0
    check_cases(cases, campaign.source)


def test_builtin_nullspace_campaign_is_valid():
    campaign = load_campaign("nullspace-planar5")
    cases = expand(campaign)
    assert len(cases) == 1 + 3 * campaign.repeat
    objectives = {c.values["controller.null_space.objective"] for c in cases[1:]}
    assert objectives == {"none", "manipulability", "joint-centering"}
    check_cases(cases, campaign.source)


def test_the_set_up_checks_warm_no_compiled_controller_up(monkeypatch):
    """check_cases builds a controller of each of compare-controllers' types (the campaign's
    process never steps them: the workers load or compile their kernels) without warming its
    compiled step up; prepare() alone does."""
    from ffsm_pin.control.compiled import CompiledController
    from ffsm_pin.sim.run import prepare

    warmed: list[str] = []
    real = CompiledController.warm_up

    def counted(self, *args):
        warmed.append(type(self).__name__)
        return real(self, *args)

    monkeypatch.setattr(CompiledController, "warm_up", counted)
    campaign = load_campaign("compare-controllers")
    cases = expand(campaign)
    check_cases(cases, campaign.source)
    assert warmed == []
    prepare(cases[0].scenario)
    assert len(warmed) == 1


def test_every_builtin_campaign_is_listed():
    assert {"robustness-case1", "nullspace-planar5"} <= set(BUILTIN_CAMPAIGNS)
    with pytest.raises(CampaignError, match="invalid TOML"):
        campaign_from_toml("[campaign", load_campaign("robustness-case1").scenario_path)


def test_actuator_and_sensor_keys_can_be_varied(campaign_file):
    """docs/controllers.md: every [actuators] and [sensors] key is a campaign axis."""
    text = SMALL + (
        '[[vary]]\nkey = "actuators.torque_limit"\nvalues = [20.0, 50.0]\n'
        '[[vary]]\nkey = "sensors.noise.joints"\nvalues = [0.001]\n'
        '[[vary]]\nkey = "sensors.delay"\nvalues = [2]\n'
    )
    cases = expand(load_campaign(campaign_file(text, "world.toml")))
    assert len(cases) == 1 + 2 * 2 * 2
    limits = set()
    for c in cases[1:]:
        sc = scenario_from_toml(c.scenario_toml)
        assert sc.actuators.torque_limit == c.values["actuators.torque_limit"]
        limits.add(sc.actuators.torque_limit)
        assert dict(sc.sensors.noise)["joints"] == 0.001 and sc.sensors.delay == 2
    assert limits == {20.0, 50.0}


def test_controller_type_and_params_can_be_varied(campaign_file):
    """docs/controllers.md: controller.type (a user's class next to the scenario file) and
    [controller.params] keys are campaign axes; the worker's scenario runs from anywhere."""
    from pathlib import Path

    from ffsm_pin.sim.run import prepare, simulate

    examples = Path(__file__).resolve().parents[2] / "examples"
    text = (
        '[campaign]\nname = "controllers"\n'
        f'scenario = "{(examples / "joint_pd_planar.toml").as_posix()}"\n'
        "seed = 1\nrepeat = 1\nduration = 0.05\n\n"
        '[[vary]]\nkey = "controller.type"\nvalues = ["lu-jia", "joint_pd.py:JointPD"]\n'
        '[[vary]]\nkey = "controller.params.kp"\nvalues = [1.0, 9.0]\n'
    )
    cases = expand(load_campaign(campaign_file(text, "controllers.toml")))
    assert len(cases) == 1 + 2 * 2
    kinds = {}
    for c in cases[1:]:
        sc = scenario_from_toml(c.scenario_toml)  # what a worker runs, without the file's folder
        assert sc.controller.params["kp"] == c.values["controller.params.kp"]
        res = simulate(prepare(sc))
        kinds[(res.controller, sc.controller.params["kp"])] = res
    assert {k for k, _ in kinds} == {"lu-jia", f"{examples / 'joint_pd.py'}:JointPD"}
    user = [r for (k, _), r in sorted(kinds.items()) if k != "lu-jia"]
    assert not np.array_equal(user[0]["u_cmd"], user[1]["u_cmd"])  # kp reached the class


def test_several_scenarios(campaign_file):
    """scenario = [a, b]: each scenario's nominal case then its grid, a ``scenario`` column,
    the same seeds for every scenario, set_for only on its scenario; each scenario's cases are
    exactly those of a campaign over it alone (same case hashes)."""
    both = load_campaign(campaign_file(TWO))
    cases = expand(both)
    assert both.columns[0] == "scenario" and len(cases) == both.n_cases == 2 * 5
    assert [c.nominal for c in cases] == [True, False, False, False, False] * 2
    assert [c.values["scenario"] for c in cases] == ["case1"] * 5 + ["planar5"] * 5
    assert [c.estimates_seed for c in cases[1:5]] == [c.estimates_seed for c in cases[6:]]
    assert {c.scenario.actuators.torque_limit for c in cases[6:]} == {100.0}
    assert all(c.scenario.actuators == cases[0].scenario.actuators for c in cases[1:5])
    alone = expand(load_campaign(campaign_file(SMALL, "alone.toml")))
    assert [c.case_hash for c in alone] == [c.case_hash for c in cases[:5]]
    assert len({c.case_hash for c in cases}) == len(cases)
    assert len({c.point_index for c in cases if not c.nominal}) == 4


@pytest.mark.parametrize(
    ("axis", "values"),
    [
        ("controller.type", ["lu-jia", "gjm-ct"]),
        ("controller.saturation", ["ignore", "auxiliary"]),
        ("controller.gamma_3", [1.0, 2.0]),
    ],
)
def test_controller_variants_draw_alike(campaign_file, axis, values):
    """Common random numbers over every controller choice (a type, an option, a gain): the
    cases that differ only in it draw the same estimates seed and dispersed values, while
    the spread (a ``controller.estimates`` key: it defines the draw) draws anew."""
    text = (
        SMALL
        + f'\n[[vary]]\nkey = "{axis}"\nvalues = {values!r}\n'.replace("'", '"')
        + '\n[campaign.disperse]\n"actuators.torque_limit" = { uniform = [50.0, 150.0] }\n'
    )
    cases = expand(load_campaign(campaign_file(text, "variants.toml")))
    by: dict[tuple, list] = {}
    for c in cases[1:]:
        key = tuple((k, v) for k, v in c.point.items() if k != axis) + (c.repeat,)
        by.setdefault(key, []).append(c)
    assert by and all(len(group) == len(values) for group in by.values())
    for group in by.values():
        assert len({c.values[axis] for c in group}) == len(values)
        assert len({c.estimates_seed for c in group}) == 1
        assert len({c.values["actuators.torque_limit"] for c in group}) == 1
    assert len({group[0].estimates_seed for group in by.values()}) == len(by)


def test_controllers_draw_alike_at_one_grid_point(campaign_file):
    """Common random numbers: cases that differ only in controller.type draw the same
    estimates seed, sampled and dispersed values, so the report's paired comparison compares
    controllers on the same draws (issue 41); other axes still change the draws."""
    text = (
        SMALL
        + '\n[[vary]]\nkey = "controller.type"\nvalues = ["lu-jia", "gjm-ct"]\n'
        + '\n[campaign.disperse]\n"actuators.torque_limit" = { uniform = [50.0, 150.0] }\n'
    )
    cases = expand(load_campaign(campaign_file(text, "crn.toml")))
    by = {}
    for c in cases[1:]:
        key = tuple((k, v) for k, v in c.point.items() if k != "controller.type") + (c.repeat,)
        by.setdefault(key, []).append(c)
    assert by and all(len(group) == 2 for group in by.values())
    for a, b in by.values():
        assert a.values["controller.type"] != b.values["controller.type"]
        assert a.estimates_seed == b.estimates_seed
        assert a.values["actuators.torque_limit"] == b.values["actuators.torque_limit"]
    seeds = {group[0].estimates_seed for group in by.values()}
    assert len(seeds) == len(by)  # every other grid point and repeat draws anew
