"""``[robot.satellite.wheels]`` (issue 40): its keys, refusals and the round trip
(ffsm_pin/scenario/wheels_spec.py, ffsm_pin/scenario/writer.py)."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.errors import ScenarioError
from ffsm_pin.robot.wheels import Wheels
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml

REALISTIC = builtin_path("spatial-realistic").read_text()
THREE = "\n[robot.satellite.wheels]\ninertia = 0.05\nmax_torque = 0.2\nmax_momentum = 4.0\n"
FOUR = """
[robot.satellite.wheels]
axes = [[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]]
inertia = [0.05, 0.05, 0.05, 0.08]
max_torque = [0.2, 0.2, 0.2, 0.3]
control = "attitude-pd"
kp = 2.0
kd = 5.0
"""


def test_the_keys_are_read():
    w = scenario_from_toml(REALISTIC + FOUR).robot.wheels
    assert w.n == 4
    np.testing.assert_allclose(w.axes[:, 3], np.ones(3) / np.sqrt(3), rtol=1e-15)
    np.testing.assert_array_equal(w.axes[:, :3], np.eye(3))
    assert w.inertia.tolist() == [0.05, 0.05, 0.05, 0.08]
    assert w.max_torque.tolist() == [0.2, 0.2, 0.2, 0.3]
    assert np.isinf(w.max_momentum).all()
    assert (w.control, w.kp, w.kd) == ("attitude-pd", 2.0, 5.0)
    three = scenario_from_toml(REALISTIC + THREE).robot.wheels
    assert three == Wheels("xyz", 0.05, 0.2, 4.0) and three.control == "none"


@pytest.mark.parametrize("table", [THREE, FOUR])
def test_round_trip(table):
    sc = scenario_from_toml(REALISTIC + table)
    text = scenario_to_toml(sc)
    again = scenario_from_toml(text)
    assert again.robot.wheels == sc.robot.wheels and again.robot == sc.robot
    assert scenario_to_toml(again) == text
    # a robot section is a cache key (a campaign's shared robots): hashable, by value
    assert hash(again.robot) == hash(sc.robot) and len({again.robot, sc.robot}) == 1
    assert "[robot.satellite.wheels]" not in scenario_to_toml(scenario_from_toml(REALISTIC))


def test_wheels_alone_add_no_satellite_body():
    """A [robot.satellite] table holding only the wheels puts them on the URDF's own bus: no
    satellite body is added, and the saved scenario says the same."""
    text = REALISTIC.replace("[robot.satellite]", "[robot.unused]")
    start = text.index("[robot.unused]")
    text = text[:start] + text[text.index("[initial]") :]
    sc = scenario_from_toml(text + THREE)
    assert sc.robot.satellite is None and sc.robot.wheels is not None
    saved = scenario_to_toml(sc)
    assert "[robot.satellite]\n" not in saved and "[robot.satellite.wheels]" in saved
    assert scenario_from_toml(saved).robot == sc.robot


BAD = {
    "zero inertia": ("inertia = 0.0", "robot.satellite.wheels.inertia: every value must be > 0"),
    "negative inertia": ("inertia = [0.1, -0.1, 0.1]", "wheels.inertia: every value must be > 0"),
    "inertia count": ("inertia = [0.1, 0.1]", "wheels.inertia: expected one number or 3"),
    "axes shape": ("axes = [[1.0, 0.0], [0.0, 1.0]]", "wheels.axes: expected 'xyz' or a 3 x N"),
    "ragged axes": ("axes = [[1.0], [0.0, 1.0], [0.0]]", "wheels.axes: expected 3 rows of N"),
    "zero axis": ("axes = [[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]]", "wheel(s) [0] have a zero"),
    "axes word": ('axes = "xy"', "wheels.axes: 'xy' unknown; give 'xyz' or a 3 x N matrix"),
    "torque limit": ("max_torque = 0.0", "wheels.max_torque = 0.0: must be > 0"),
    "momentum limit": ("max_momentum = -1.0", "wheels.max_momentum = -1.0: must be > 0"),
    "control": ('control = "pd"', "valid choices: 'none', 'attitude-pd'"),
    "gain": ("kp = -1.0", "wheels.kp = -1.0"),
    "unknown key": ("spin = 1.0", "unknown key in [robot.satellite.wheels]; valid keys: 'axes'"),
}


@pytest.mark.parametrize("what", sorted(BAD))
def test_bad_wheels_are_one_line_naming_the_key(what):
    line, fragment = BAD[what]
    key = line.split(" = ")[0]
    table = "\n[robot.satellite.wheels]\n" + ("" if key == "inertia" else "inertia = 0.1\n")
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(REALISTIC + table + line + "\n")
    msg = str(info.value)
    assert "\n" not in msg and fragment in msg, msg


def test_wheels_without_inertia_and_on_a_planar_robot_are_refused():
    with pytest.raises(ScenarioError, match=r"wheels\.inertia: missing"):
        scenario_from_toml(REALISTIC + "\n[robot.satellite.wheels]\naxes = 'xyz'\n")
    planar = builtin_path("case1").read_text()
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(planar + "\n[robot.satellite.wheels]\ninertia = 0.1\n")
    msg = str(info.value)
    assert "\n" not in msg and "wheels apply only to base = 'free-flyer'" in msg, msg
