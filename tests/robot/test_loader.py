"""Loader validation: every bad input is refused with its own exception type and a message that
names the offending item; sloppy-but-usable input loads with a warning; the shipped robot's
geometry is the paper's Table 1."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.errors import (
    FrameNotFoundError,
    InertiaError,
    ParameterError,
    RobotFileError,
    UnsupportedJointError,
    UrdfError,
)
from ffsm_pin.robot import UrdfWarning, load_robot, shipped_urdfs, urdf_dir

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


# (file in tests/data, exact exception type, strings the message must contain)
BAD_INPUTS = [
    ("bad_prismatic.urdf", UnsupportedJointError, ["'slider'", "prismatic"]),
    ("bad_x_axis.urdf", UnsupportedJointError, ["'elbow'", "axis"]),
    ("bad_roll_origin.urdf", UnsupportedJointError, ["'wrist'", "roll"]),
    ("bad_zero_mass.urdf", InertiaError, ["'massless_link'", "mass"]),
    ("bad_branching.urdf", UnsupportedJointError, ["'right_joint'", "serial"]),
    ("bad_malformed.urdf", UrdfError, ["XML"]),
]


@pytest.mark.parametrize(
    ("name", "exc_type", "needles"), BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS]
)
def test_bad_urdf_is_refused_with_specific_error(data_dir, name, exc_type, needles):
    with pytest.raises(UrdfError) as info:
        load_robot(data_dir / name)
    # the exact class, not merely some UrdfError
    assert info.type is exc_type, f"{name}: got {info.type.__name__}: {info.value}"
    assert isinstance(info.value, ValueError)  # generic handlers still work
    message = str(info.value)
    assert name in message  # names the file ...
    for needle in needles:  # ... and the offending joint/link
        assert needle in message, f"{needle!r} not in {message!r}"


def test_root_element_must_be_robot(tmp_path):
    path = tmp_path / "not_a_robot.urdf"
    path.write_text('<?xml version="1.0"?>\n<sdf version="1.6"><model name="m"/></sdf>\n')
    with pytest.raises(UrdfError, match=r"<sdf>.*<robot>"):
        load_robot(path)


def test_missing_file_is_robot_file_error(tmp_path):
    missing = tmp_path / "nowhere" / "ghost.urdf"
    with pytest.raises(RobotFileError) as info:
        load_robot(missing)
    assert isinstance(info.value, FileNotFoundError)
    assert "ghost.urdf" in str(info.value)
    assert "'ffsm_planar4.urdf'" in str(info.value)  # lists the shipped robots


def test_unknown_base_lists_choices():
    with pytest.raises(UnsupportedJointError, match=r"'spherical'.*'planar', 'free-flyer'"):
        load_robot("ffsm_planar4.urdf", base="spherical")


def test_unknown_frame_lists_frames_and_suggests_close_one():
    with pytest.raises(FrameNotFoundError) as info:
        load_robot("ffsm_planar4.urdf", end_effector="ee_lnk")
    message = str(info.value)
    assert isinstance(info.value, ValueError)
    assert "'ee_lnk'" in message
    assert "did you mean 'ee_link'" in message
    for frame in ("'ee'", "'ee_link'", "'base_link'", "'link4'", "'joint4'"):
        assert frame in message  # the valid frames


def test_end_effector_on_the_base_is_refused():
    with pytest.raises(FrameNotFoundError, match="'base_link'"):
        load_robot("ffsm_planar4.urdf", end_effector="base_link")


def test_end_effector_on_an_inner_link(paper_robot):
    robot = load_robot("ffsm_planar4.urdf", end_effector="link3")
    assert robot.geometry.ee_body == 3
    np.testing.assert_array_equal(robot.geometry.ee_position, [0.0, 0.0])
    # the default end effector is link 4's tip
    assert paper_robot.geometry.ee_body == 4
    np.testing.assert_array_equal(paper_robot.geometry.ee_position, [1.4, 0.0])


def test_missing_limit_loads_with_warning(data_dir):
    with pytest.warns(UrdfWarning, match="'free_joint'"):
        robot = load_robot(data_dir / "no_limit.urdf")
    assert issubclass(UrdfWarning, UserWarning)
    assert robot.n_joints == 2
    assert robot.model.nq == 4 + 2  # planar root (x, y, cos, sin) + two revolute joints
    np.testing.assert_array_equal(robot.geometry.axis_signs, [1.0, -1.0])
    assert "<limit" in robot.urdf_xml.split('name="free_joint"')[1].split("</joint>")[0]


def test_continuous_joint_loads_as_revolute_with_warning(data_dir, tmp_path):
    text = (data_dir / "no_limit.urdf").read_text()
    path = tmp_path / "continuous.urdf"
    path.write_text(
        text.replace('name="free_joint" type="revolute"', 'name="free_joint" type="continuous"')
    )
    with pytest.warns(UrdfWarning) as record:
        robot = load_robot(path)
    messages = [str(w.message) for w in record]
    assert any("'free_joint'" in m and "continuous" in m for m in messages), messages
    assert any("'free_joint'" in m and "<limit>" in m for m in messages), messages
    # Pinocchio would make a continuous joint a 2-coordinate (cos, sin) joint
    assert robot.model.nq == 4 + 2
    assert robot.model.nv == 3 + 2


def test_clean_urdf_loads_without_warning(data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_robot("ffsm_planar4.urdf")
        load_robot(data_dir / "planar5_offaxis.urdf")


def test_shipped_robot_found_by_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # not relative to the working directory
    assert "ffsm_planar4.urdf" in shipped_urdfs()
    robot = load_robot("ffsm_planar4.urdf")
    assert robot.urdf_path.resolve() == (urdf_dir() / "ffsm_planar4.urdf").resolve()
    assert robot.name == "ffsm_planar4"
    assert robot.n_joints == 4
    assert robot.ee_frame == "ee"


def test_relative_to(data_dir, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    robot = load_robot("planar5_collinear.urdf", relative_to=data_dir)
    assert robot.urdf_path.resolve() == (data_dir / "planar5_collinear.urdf").resolve()
    assert robot.n_joints == 5


def test_paper_geometry_matches_table(paper_robot):
    table = tomllib.loads((urdf_dir() / "ffsm_planar4.toml").read_text())
    g = paper_robot.geometry
    links = table["links"]
    # Table 1 of the paper, via the TOML table. Masses and inertias are exact (the URDF
    # writes repr(float)); CoMs pass through a Pinocchio SE3 action: a few ulps.
    np.testing.assert_array_equal(g.masses, [table["base"]["mass"]] + [lk["mass"] for lk in links])
    np.testing.assert_array_equal(
        g.inertias, [table["base"]["inertia"]] + [lk["inertia"] for lk in links]
    )
    np.testing.assert_allclose(
        g.coms, [table["base"]["com"]] + [lk["com"] for lk in links], rtol=0, atol=1e-14
    )
    np.testing.assert_array_equal(g.child_joints[0], [0.8, 0.0])  # l_c0 = 0.8 m mount
    np.testing.assert_array_equal(g.child_joints[1:], [[lk["length"], 0.0] for lk in links[:-1]])
    np.testing.assert_array_equal(g.ee_position, [links[-1]["length"], 0.0])
    np.testing.assert_array_equal(g.axis_signs, [1.0] * 4)
    np.testing.assert_array_equal(g.joint_yaws, [0.0] * 4)
    assert g.ee_body == 4 and g.ee_yaw == 0.0
    assert g.total_mass == pytest.approx(61.2 + 6.3 + 5.4 + 5.1 + 5.1, abs=1e-12)
    assert paper_robot.body_names == ("base_link", "link1", "link2", "link3", "link4")


def test_geometry_is_read_only(paper_robot):
    with pytest.raises(ValueError):
        paper_robot.geometry.masses[0] = 1.0


def test_configuration_checks_joint_count(paper_robot):
    q = paper_robot.configuration((1.0, 2.0, 0.3), [0.1, 0.2, 0.3, 0.4])
    np.testing.assert_allclose(q[:4], [1.0, 2.0, np.cos(0.3), np.sin(0.3)], rtol=0, atol=1e-15)
    with pytest.raises(ParameterError, match="4 joint angles"):
        paper_robot.configuration((0.0, 0.0, 0.0), [0.1, 0.2])


def test_tilted_fixed_joint_file_is_really_not_planar(data_dir):
    """The data file of the xfail test below is a genuine bad input: Pinocchio's own parse puts
    joint2's axis 0.5 rad away from the plane's normal."""
    model = pin.buildModelFromUrdf(str(data_dir / "bad_tilted_fixed.urdf"), pin.JointModelPlanar())
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    axis_world = data.oMi[model.getJointId("joint2")].rotation[:, 2]
    assert axis_world[2] == pytest.approx(np.cos(0.5), abs=1e-12)


def test_tilted_fixed_joint_is_refused(data_dir):
    with pytest.raises(UnsupportedJointError, match="'joint2'|'tilt'"):
        load_robot(data_dir / "bad_tilted_fixed.urdf")
