"""``[initial] attitude_error`` (issue 41): a base attitude error on top of ``base_pose``, planar
an angle, spatial a rotation vector about inertial axes; written back by the scenario file;
wrong sizes are one line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.errors import ScenarioError
from ffsm_pin.robot import load_robot
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.initial import initial_state


def _with(case: str, line: str):
    text = builtin_path(case).read_text()
    return scenario_from_toml(text.replace("[initial]\n", f"[initial]\n{line}\n", 1))


def test_planar_adds_the_angle():
    sc = _with("case1", "attitude_error = -0.05")
    robot = load_robot(sc.robot.urdf, sc.robot.end_effector)
    q, _ = initial_state(robot, sc.initial)
    q0, _ = initial_state(robot, dataclasses.replace(sc.initial, attitude_error=None))
    angle = np.arctan2(q[3], q[2]) - np.arctan2(q0[3], q0[2])
    assert angle == pytest.approx(-0.05, abs=1e-12)
    assert scenario_from_toml(scenario_to_toml(sc)).initial.attitude_error == -0.05


def test_spatial_turns_about_the_rotation_vector():
    sc = _with("spatial-pose", "attitude_error = [0.02, -0.03, 0.05]")
    robot = load_robot(sc.robot.urdf, sc.robot.end_effector, base="free-flyer")
    q, _ = initial_state(robot, sc.initial)
    q0, _ = initial_state(robot, dataclasses.replace(sc.initial, attitude_error=None))
    R, R0 = (pin.Quaternion(x[3:7]).matrix() for x in (q, q0))
    np.testing.assert_allclose(pin.log3(R @ R0.T), [0.02, -0.03, 0.05], atol=1e-12)
    again = scenario_from_toml(scenario_to_toml(sc)).initial.attitude_error
    assert again == (0.02, -0.03, 0.05)


@pytest.mark.parametrize(
    ("case", "line", "expected"),
    [
        ("case1", "attitude_error = [0.1]", "initial.attitude_error: expected a number"),
        ("spatial-pose", "attitude_error = 0.1", "initial.attitude_error: expected 3 numbers"),
        (
            "spatial-pose",
            "attitude_error = [0.1, 0.2]",
            "initial.attitude_error: 2 values, expected 3",
        ),
        ("case1", 'attitude_error = "big"', "initial.attitude_error"),
    ],
)
def test_wrong_sizes_are_one_line(case, line, expected):
    with pytest.raises(ScenarioError) as err:
        _with(case, line)
    assert expected in str(err.value) and "\n" not in str(err.value)
