"""Effort limits that exist (issue 37): the URDF repair's placeholder is never a torque limit;
what the C++ URDF parser prints is captured and folded into one message."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.errors import RobotFileError, ScenarioError, UrdfError
from ffsm_pin.robot import load_robot, urdf_dir
from ffsm_pin.robot.native import native_output, summary
from ffsm_pin.robot.urdf import UrdfWarning, resolve_urdf
from ffsm_pin.sim.actuators import urdf_limits

DATA = Path(__file__).resolve().parents[1] / "data"


def _load(path: Path, ee: str = "ee"):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_robot(path, ee)
    return robot, [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]


def test_joint_without_limit_has_no_effort_limit():
    robot, warned = _load(DATA / "no_limit.urdf")
    assert robot.no_effort_limit == ("free_joint",)
    effort = robot.effort_limits
    assert effort.shape == (robot.n_joints,)
    assert effort[0] == 100.0 and np.isnan(effort[1])  # joint1 gives 100 N m, free_joint none
    assert len(warned) == 1 and "'free_joint'" in warned[0] and "no torque limit" in warned[0]


def test_shipped_robot_keeps_its_effort_limits():
    robot, warned = _load(urdf_dir() / "ffsm_planar4.urdf")
    assert robot.no_effort_limit == () and warned == []
    assert np.all(np.isfinite(robot.effort_limits)) and np.all(robot.effort_limits > 0)


def test_continuous_joint_keeps_its_effort_and_gets_position_limits(tmp_path):
    urdf = (DATA / "no_limit.urdf").read_text()
    urdf = urdf.replace(
        '<joint name="free_joint" type="revolute">', '<joint name="free_joint" type="continuous">'
    ).replace('<axis xyz="0 0 -1"/>', '<axis xyz="0 0 -1"/><limit effort="7.5" velocity="2"/>')
    (tmp_path / "cont.urdf").write_text(urdf)
    robot, warned = _load(tmp_path / "cont.urdf")
    assert robot.no_effort_limit == ()
    assert robot.effort_limits[1] == 7.5
    assert robot.model.upperPositionLimit[-1] == pytest.approx(2 * np.pi)
    assert any("'free_joint'" in w and "continuous" in w for w in warned)


def test_urdf_limits_name_the_joints_without_effort():
    with pytest.raises(ScenarioError) as info:
        urdf_limits(np.array([10.0, np.nan, 0.0]), 3, ("a", "b", "c"))
    text = str(info.value)
    assert "'b'" in text and "'c'" in text and "'a'" not in text
    assert "torque_limit = 50.0" in text
    assert np.array_equal(urdf_limits(np.array([10.0, 2.0]), 2, ("a", "b")), [10.0, 2.0])


def test_folder_as_urdf_is_named_a_folder(tmp_path):
    (tmp_path / "arm.urdf").mkdir()
    with pytest.raises(RobotFileError, match="is a folder, not a file"):
        resolve_urdf("arm.urdf", tmp_path)


# ------------------------------------------------------------------------ captured C++ output
def test_native_output_captures_descriptors_and_restores_them(capfd):
    with native_output() as said:
        os.write(1, b"Info: one\n")
        os.write(2, b"Error:   two\n         at line 3 in /src/x.cpp\n")
    os.write(2, b"after\n")
    assert said.has_errors
    assert said.summary() == "one; two"
    out, err = capfd.readouterr()
    assert "one" not in out and "two" not in err and err == "after\n"


def test_summary_is_one_short_line():
    text = "Error: " + "x" * 1000 + "\nError: " + "x" * 1000 + "\n"
    line = summary(text)
    assert "\n" not in line and len(line) <= 300 and line.endswith("...")


def test_urdfdom_errors_are_one_urdf_error_and_print_nothing(capfd):
    with pytest.raises(UrdfError) as info:
        load_robot(DATA / "bad_mass_text.urdf", "link1")
    text = str(info.value)
    assert text.startswith("bad_mass_text.urdf:") and "mass" in text and "\n" not in text
    assert ".cpp" not in text  # source locations of the C++ library are left out
    out, err = capfd.readouterr()
    assert out == "" and err == ""
