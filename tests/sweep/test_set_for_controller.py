"""``[campaign.set_for_controller."<type>"]`` (issue 41): keys set only in the cases of one
controller type, so a user's controller with its own ``[controller.params]`` runs beside the
built-ins in one campaign; a table for a type the campaign does not have, or a key that
another table sets too, is one ``error:`` line (exit 2, nothing written)."""

from __future__ import annotations

import textwrap

import pytest

from ffsm_pin.scenario.file import builtin_path
from ffsm_pin.sim.run import prepare, simulate
from ffsm_pin.sweep import cli
from ffsm_pin.sweep.campaign import CampaignError, load_campaign
from ffsm_pin.sweep.cases import expand
from ffsm_pin.sweep.check import check_cases
from ffsm_pin.sweep.engine import run_case

# a user's controller that, like the baselines, declares the keys it accepts (params_keys:
# any other is refused before it is built) and needs both
STRICT_PD = '''
import numpy as np


class StrictPD:
    """u_m = kp (q_m(0) - q_m) - kd w_m; [controller.params] kp and kd, nothing else."""

    params_keys = ("kp", "kd")

    def __init__(self, ctx):
        self.kp, self.kd = float(ctx.params["kp"]), float(ctx.params["kd"])
        self.target, self.m3 = np.array(ctx.initial.q_m), ctx.m3

    def step(self, meas):
        return self.kp * (self.target - meas.q_m) - self.kd * meas.w[self.m3 :]
'''


@pytest.fixture
def user_type(tmp_path):
    (tmp_path / "strict_pd.py").write_text(STRICT_PD)
    return f"{tmp_path / 'strict_pd.py'}:StrictPD"  # absolute: the scenario is a built-in


def mixed(user: str, extra: str = "") -> str:
    return (
        textwrap.dedent(f"""\
        [campaign]
        name = "mixed"
        scenario = "case1"
        seed = 5
        repeat = 1
        duration = 0.2
        dt = 0.002

        [campaign.set]
        "controller.estimates.initial" = "perturbed"

        [campaign.set_for_controller."{user}"]
        "controller.params.kp" = 40.0
        "controller.params.kd" = 5.0

        [campaign.set_for_controller.gjm-ct]
        "controller.params.k_v" = 30.0

        [[vary]]
        key = "controller.type"
        values = ["gjm-ct", "{user}"]

        [[vary]]
        key = "controller.estimates.spread"
        values = [0.1, 0.2]
        """)
        + extra
    )


def test_a_users_controller_runs_beside_gjm_ct(campaign_file, user_type):
    campaign = load_campaign(campaign_file(mixed(user_type)))
    cases = expand(campaign)
    check_cases(cases, campaign.source)  # every grid point prepares: nothing refused
    grid = [c for c in cases if not c.nominal]
    assert [c.values["controller.type"] for c in grid] == ["gjm-ct"] * 2 + [user_type] * 2
    for case in grid:
        setup = prepare(case.scenario)
        if case.scenario.controller.type == "gjm-ct":
            assert dict(case.scenario.controller.params) == {"k_v": 30.0}
            assert setup.controller.gains.k_v == 30.0
        else:
            assert dict(case.scenario.controller.params) == {"kp": 40.0, "kd": 5.0}
            assert (setup.controller.kp, setup.controller.kd) == (40.0, 5.0)
        assert simulate(setup).completed
        row = run_case(case.scenario_toml)  # as a campaign worker runs it
        assert row["status"] == "completed", row["error"]


def test_set_for_controller_applies_to_that_types_cases_only(campaign_file):
    text = textwrap.dedent("""\
        [campaign]
        scenario = ["case1", "planar5"]
        duration = 1.0

        [campaign.set_for_controller.gjm-ct]
        "controller.params.k_v" = 25.0
        "actuators.torque_limit" = 80.0

        [campaign.set_for_controller.adaptive-ct]
        "controller.params.k_s" = 4.0

        [[vary]]
        key = "controller.type"
        values = ["lu-jia", "gjm-ct", "adaptive-ct"]
        """)
    cases = expand(load_campaign(campaign_file(text)))
    assert len(cases) == 2 * (1 + 3)
    for case in cases:
        sc = case.scenario  # the resolved scenario of the case
        kind = sc.controller.type
        if case.nominal:  # the scenario file as it is (only the run length applied)
            assert kind == "lu-jia" and dict(sc.controller.params) == {}
            assert sc.actuators.torque_limit == "none"
        elif kind == "gjm-ct":
            assert dict(sc.controller.params) == {"k_v": 25.0}
            assert sc.actuators.torque_limit == 80.0
        elif kind == "adaptive-ct":
            assert dict(sc.controller.params) == {"k_s": 4.0}
            assert sc.actuators.torque_limit == "none"
        else:
            assert kind == "lu-jia" and dict(sc.controller.params) == {}
            assert sc.actuators.torque_limit == "none"
        assert ("k_v = 25.0" in case.scenario_toml) == (kind == "gjm-ct" and not case.nominal)


def test_the_scenarios_own_type_has_its_table(campaign_file, tmp_path, user_type):
    """Without a varied type, a case's type is its scenario's (or campaign.set's)."""
    text = builtin_path("case1").read_text()
    mine = text.replace("[controller]\n", f'[controller]\ntype = "{user_type}"\n')
    (tmp_path / "mine.toml").write_text(mine)
    campaign = textwrap.dedent(f"""\
        [campaign]
        scenario = ["mine.toml", "case1"]
        duration = 0.2

        [campaign.set_for_controller."{user_type}"]
        "controller.params.kp" = 10.0
        "controller.params.kd" = 1.0

        [[vary]]
        key = "sim.dt"
        values = [0.002]
        """)
    cases = expand(load_campaign(campaign_file(campaign)))
    by = {(c.scenario.controller.type, c.nominal): c for c in cases}
    assert len(by) == len(cases) == 4
    assert dict(by[(user_type, False)].scenario.controller.params) == {"kp": 10.0, "kd": 1.0}
    assert dict(by[(user_type, True)].scenario.controller.params) == {}  # the file as it is
    assert dict(by[("lu-jia", False)].scenario.controller.params) == {}


def test_without_it_the_users_keys_are_refused_for_gjm_ct_with_a_hint(campaign_file, user_type):
    """What the new user met: the keys set for every case reach gjm-ct, which refuses them;
    the one line now says where a controller's own keys go."""
    text = (
        mixed(user_type)
        .replace(f'[campaign.set_for_controller."{user_type}"]\n', "")
        .replace(  # the user's keys now in [campaign.set], for every case
            '"controller.estimates.initial" = "perturbed"\n\n',
            '"controller.estimates.initial" = "perturbed"\n',
        )
    )
    campaign = load_campaign(campaign_file(text))
    assert campaign.set["controller.params.kp"] == 40.0 and not campaign.set_for_controller.get(
        user_type
    )
    with pytest.raises(CampaignError) as info:
        check_cases(expand(campaign), campaign.source)
    message = str(info.value)
    assert "\n" not in message
    assert "controller.params.kp: unknown for controller.type 'gjm-ct'" in message
    assert '[campaign.set_for_controller."<type>"]' in message


NOT_TABLES = '[campaign]\nscenario = "case1"\nset_for_controller = { gjm-ct = 3 }\n'
LU_JIA_TABLE = '\n[campaign.set_for_controller.lu-jia]\n"controller.k_z" = 1.0\n'
BAD = {
    "a type the campaign does not have": (
        lambda user: mixed(user).replace("set_for_controller.gjm-ct", "set_for_controller.gjm"),
        "campaign.set_for_controller.gjm: not a controller type of this campaign's cases "
        "(did you mean 'gjm-ct'?); valid choices: 'gjm-ct', ",
    ),
    "the scenario's type when the type is varied": (
        lambda user: mixed(user, LU_JIA_TABLE),
        "campaign.set_for_controller.lu-jia: not a controller type of this campaign's cases",
    ),
    "the controller type itself": (
        lambda user: mixed(user).replace(
            '"controller.params.k_v" = 30.0', '"controller.type" = "adaptive-ct"'
        ),
        "campaign.set_for_controller.gjm-ct.controller.type: the controller type is what picks",
    ),
    "a key every case sets": (
        lambda user: mixed(user).replace(
            '"controller.params.k_v" = 30.0', '"controller.estimates.initial" = "true"'
        ),
        "campaign.set_for_controller.gjm-ct.controller.estimates.initial: also set for every "
        "case",
    ),
    "a varied key": (
        lambda user: mixed(user).replace(
            '"controller.params.k_v" = 30.0', '"controller.estimates.spread" = 0.3'
        ),
        "controller.estimates.spread: also set for every case",
    ),
    "the run length given as campaign.duration": (
        lambda user: mixed(user).replace('"controller.params.k_v" = 30.0', '"sim.duration" = 1.0'),
        "campaign.set_for_controller.gjm-ct.sim.duration: also set for every case",
    ),
    "a key of a scenario's table too": (
        lambda user: mixed(user, '\n[campaign.set_for.case1]\n"controller.params.k_v" = 20.0\n'),
        "campaign.set_for_controller.gjm-ct.controller.params.k_v: given twice (also in "
        "campaign.set_for.case1)",
    ),
    "not a table of tables": (
        lambda user: NOT_TABLES,
        "campaign.set_for_controller: expected a table of tables (one per controller type)",
    ),
    "a quoted user's type misspelt": (
        lambda user: mixed(user).replace(f'controller."{user}"]', 'controller."x.py:C"]'),
        "campaign.set_for_controller.\"x.py:C\": not a controller type",
    ),
}  # fmt: skip


@pytest.mark.parametrize("what", list(BAD))
def test_bad_set_for_controller_is_one_error_line(what, campaign_file, tmp_path, capsys, user_type):
    make, fragment = BAD[what]
    path = campaign_file(make(user_type))
    out = tmp_path / "out"
    status = cli.main([str(path), "--out", str(out), "--workers", "1"])
    err = capsys.readouterr()
    assert status == 2, err.err
    lines = err.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in err.err and err.out == ""
    assert not out.exists()
