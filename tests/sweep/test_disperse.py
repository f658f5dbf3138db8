"""``[campaign.disperse]`` (issue 41): any numeric scenario key drawn per case, each from its own
stream (adding a key leaves the others' draws alone), element-wise for vectors, a random
direction for an attitude error; the drawn value is in the case's resolved scenario (or the
campaign is refused), is the run's, and is a column of results.parquet; bad input is one
line."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pyarrow.parquet as pq
import pytest

from ffsm_pin.scenario.file import scenario_from_toml
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.setup import prepare
from ffsm_pin.sweep import cli
from ffsm_pin.sweep.campaign import CampaignError, load_campaign
from ffsm_pin.sweep.cases import expand

HEAD = """\
[campaign]
scenario = "{scenario}"
seed = 5
repeat = {repeat}
duration = {duration}

[campaign.disperse]
"""


def _campaign(campaign_file, lines, *, scenario="case1", repeat=4, duration=1.0, name="c.toml"):
    text = HEAD.format(scenario=scenario, repeat=repeat, duration=duration) + "\n".join(lines)
    return load_campaign(campaign_file(text + "\n", name))


K_Z = '"controller.k_z" = { uniform = [0.02, 0.06] }'
GAMMA = '"controller.gamma_1" = { normal = [10.0, 1.0] }'
LIMIT = '"actuators.torque_limit" = { uniform = [20.0, 60.0] }'


def test_each_key_has_its_own_stream(campaign_file):
    one = expand(_campaign(campaign_file, [K_Z], name="one.toml"))
    two = expand(_campaign(campaign_file, [GAMMA, K_Z], name="two.toml"))
    three = expand(_campaign(campaign_file, [K_Z, LIMIT, GAMMA], name="three.toml"))
    for key in ("controller.k_z",):
        a = [c.values[key] for c in one[1:]]
        assert a == [c.values[key] for c in two[1:]] == [c.values[key] for c in three[1:]]
        assert len(set(a)) == len(a) and all(0.02 <= x <= 0.06 for x in a)
    gamma = [c.values["controller.gamma_1"] for c in two[1:]]
    assert gamma == [c.values["controller.gamma_1"] for c in three[1:]]
    # the same campaign again draws the same values; another root seed others
    again = expand(_campaign(campaign_file, [GAMMA, K_Z], name="again.toml"))
    assert [c.values for c in again] == [c.values for c in two]
    other = load_campaign(
        campaign_file(
            HEAD.format(scenario="case1", repeat=4, duration=1.0).replace("seed = 5", "seed = 6")
            + K_Z
            + "\n",
            "other.toml",
        )
    )
    assert [c.values["controller.k_z"] for c in expand(other)[1:]] != [
        c.values["controller.k_z"] for c in one[1:]
    ]
    # the nominal case is the scenario file's
    assert one[0].values["controller.k_z"] == 0.04


def test_the_drawn_values_are_the_resolved_scenarios(campaign_file):
    cases = expand(_campaign(campaign_file, [K_Z, LIMIT, GAMMA]))
    for c in cases[1:]:
        sc = scenario_from_toml(c.scenario_toml)  # what the worker runs
        assert sc.controller.lu_jia.gains.k_z == c.values["controller.k_z"]
        assert sc.controller.lu_jia.gains.gamma_1 == c.values["controller.gamma_1"]
        assert sc.actuators.torque_limit == c.values["actuators.torque_limit"]
        assert 20.0 <= sc.actuators.torque_limit <= 60.0


def test_vectors_are_drawn_element_wise(campaign_file):
    # case 1's rho_z0 = [1.0, 1.0, 0.2]: numbers broadcast to its 3 components, lists per one
    lines = [
        '"controller.funnel.rho_z0" = { uniform = [1.2, 1.5] }',
        '"initial.joints" = { normal = [[0.1, 0.2, 0.3, 0.4], [0.01, 0.01, 0.01, 0.01]] }',
    ]
    cases = expand(_campaign(campaign_file, lines))
    for c in cases[1:]:
        rho = c.values["controller.funnel.rho_z0"]
        assert len(rho) == 3 and len(set(rho)) == 3 and all(1.2 <= x <= 1.5 for x in rho)
        assert scenario_from_toml(c.scenario_toml).performance.funnel_z.rho0 == tuple(rho)
        joints = np.array(c.values["initial.joints"])
        assert np.all(np.abs(joints - [0.1, 0.2, 0.3, 0.4]) < 0.06)


def test_an_attitude_error_in_a_random_direction(campaign_file):
    cases = expand(
        _campaign(
            campaign_file,
            ['"initial.attitude_error" = { angle = 0.05 }'],
            scenario="spatial",
            repeat=6,
        )
    )
    axes = []
    for c in cases[1:]:
        e = np.array(c.values["initial.attitude_error"])
        assert e.shape == (3,) and math.isclose(np.linalg.norm(e), 0.05, rel_tol=1e-12)
        assert scenario_from_toml(c.scenario_toml).initial.attitude_error == tuple(e)
        axes.append(e / 0.05)
    assert np.linalg.matrix_rank(np.array(axes), tol=1e-3) == 3  # directions differ
    planar = expand(
        _campaign(
            campaign_file, ['"initial.attitude_error" = { angle = 0.1 }'], repeat=8, name="p.toml"
        )
    )
    assert {c.values["initial.attitude_error"] for c in planar[1:]} == {0.1, -0.1}


def test_a_dispersed_torque_limit_is_the_runs(campaign_file):
    """The limit reaches the run: the applied torques respect it, and it acts (saturation)."""
    lines = ['"actuators.torque_limit" = { uniform = [4.0, 6.0] }']
    case = expand(_campaign(campaign_file, lines, repeat=1, duration=0.3))[1]
    limit = case.values["actuators.torque_limit"]
    sc = scenario_from_toml(case.scenario_toml)
    assert sc.actuators.torque_limit == limit and 4.0 <= limit <= 6.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(prepare(sc))
    u = np.asarray(result.signals["u_m"])
    assert np.abs(u).max() <= limit + 1e-12
    assert np.abs(u).max() == pytest.approx(limit)  # the limit acted


def test_a_dispersion_that_does_not_reach_the_scenario_is_refused(campaign_file):
    """case 1 has no null-space term: a gain drawn for it would be written nowhere (a silent
    dispersion, Basilisk #1164)."""
    with pytest.raises(CampaignError, match="cannot be dispersed"):
        expand(
            _campaign(campaign_file, ['"controller.null_space.gain" = { uniform = [1.0, 2.0] }'])
        )


def test_the_columns_of_results_parquet(campaign_file, tmp_path):
    text = (
        HEAD.format(scenario="case1", repeat=2, duration=0.02)
        + K_Z
        + "\n"
        + ('"controller.funnel.rho_z0" = { uniform = [1.2, 1.5] }\n')
    )
    path = campaign_file(text, "run.toml")
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert cli.main([str(path), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    rows = pq.read_table(out / "results.parquet").to_pylist()
    cases = expand(load_campaign(path))
    assert len(rows) == len(cases) == 3
    for row, case in zip(sorted(rows, key=lambda r: r["case"]), cases, strict=True):
        assert row["controller.k_z"] == case.values["controller.k_z"]
        assert row["controller.funnel.rho_z0"] == case.values["controller.funnel.rho_z0"]


BAD = {
    "unknown distribution": (
        '"controller.k_z" = { gamma = [1.0, 2.0] }',
        "unknown distribution 'gamma'",
    ),
    "bounds in the wrong order": (
        '"controller.k_z" = { uniform = [0.06, 0.02] }',
        "bounds in the wrong order",
    ),
    "element bounds in the wrong order": (
        '"controller.funnel.rho_z0" = { uniform = [[1.2, 1.2, 0.3], [1.5, 1.5, 0.2]] }',
        "low[2] = 0.3 must be < high[2] = 0.2",
    ),
    "negative std": ('"controller.k_z" = { normal = [0.04, -0.01] }', "std = -0.01 must be > 0"),
    "not numeric": (
        '"controller.scheme" = { uniform = [1.0, 2.0] }',
        "controller.scheme is not numeric",
    ),
    "a boolean": ('"initial.com_at_origin" = { uniform = [0.0, 1.0] }', "is not numeric"),
    "does not exist": (
        '"controller.kz" = { uniform = [1.0, 2.0] }',
        "controller.kz is not a scenario key",
    ),
    "a table": ('"controller.funnel" = { uniform = [1.0, 2.0] }', "is a table, not a value"),
    "wrong length": ('"initial.joints" = { uniform = [[0, 0], [1, 1]] }', "has 4 values"),
    "two distributions": (
        '"controller.k_z" = { uniform = [1.0, 2.0], normal = [1.0, 1.0] }',
        "expected one of",
    ),
    "angle too large": (
        '"initial.attitude_error" = { angle = 4.0 }',
        "must be an angle in (0, pi]",
    ),
    "also varied": (
        K_Z + '\n\n[[vary]]\nkey = "controller.k_z"\nvalues = [0.1]',
        "controller.k_z: given twice",
    ),
}


@pytest.mark.parametrize("what", list(BAD))
def test_bad_dispersions_are_one_error_line(what, campaign_file, tmp_path, capsys):
    line, fragment = BAD[what]
    path = campaign_file(HEAD.format(scenario="case1", repeat=1, duration=1.0) + line + "\n")
    status = cli.main([str(path), "--out", str(tmp_path / "out"), "--workers", "1"])
    err = capsys.readouterr().err.splitlines()
    assert status == 2 and len(err) == 1 and err[0].startswith("error: "), err
    assert fragment in err[0], err[0]
    assert not (tmp_path / "out").exists()
