"""The spatial loader: example-robot-data arms, satellite body, locked joints, the generator,
and one specific error (naming the item) for each class of bad input."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin import load_robot
from ffsm_pin.errors import (
    FrameNotFoundError,
    InertiaError,
    ParameterError,
    RobotFileError,
    UnsupportedJointError,
    UrdfError,
)
from ffsm_pin.robot import EXAMPLE_ROBOTS, Satellite, load_spatial_robot
from ffsm_pin.robot.writer import chain_from_table, chain_to_urdf, read_table

PANDA_LOCK = {"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.02}


@pytest.fixture(scope="module")
def table(data_dir):
    return read_table(data_dir / "spatial3.toml")


@pytest.fixture
def urdf_text(table):
    return chain_to_urdf(chain_from_table(table))


def _write(tmp_path, text, name="robot.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_generated_chain_geometry(tmp_path, table, urdf_text):
    """The loaded geometry is the table's: masses, CoMs, inertias, axes, joint placements."""
    robot = load_spatial_robot(_write(tmp_path, urdf_text), "ee")
    g = robot.geometry
    assert robot.n_joints == 3 and g.ee_body == 3
    links = table["links"]
    assert np.allclose(g.masses, [table["base"]["mass"]] + [lk["mass"] for lk in links], rtol=0)
    assert np.allclose(g.coms[1:], [lk["com"] for lk in links], rtol=0, atol=1e-15)
    xx, yy, zz, xy, xz, yz = links[1]["inertia"]
    assert np.allclose(g.inertias[2], [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], atol=1e-15)
    for k, lk in enumerate(links):
        axis = np.array(lk["axis"]) / np.linalg.norm(lk["axis"])
        assert np.allclose(g.axes[k], axis, atol=1e-15)
        assert np.allclose(g.child_joints[k], lk["origin_xyz"], atol=1e-15)
        rpy = lk.get("origin_rpy", [0.0, 0.0, 0.0])
        assert np.allclose(g.joint_rotations[k], pin.rpy.rpyToMatrix(*rpy), atol=1e-15)
    assert np.allclose(g.ee_position, table["ee"]["xyz"], atol=1e-15)
    assert robot.model.nq == 7 + 3 and robot.model.nv == 6 + 3
    assert np.all(robot.model.gravity.linear == 0.0)


def test_load_robot_dispatches_free_flyer(tmp_path, urdf_text):
    robot = load_robot(_write(tmp_path, urdf_text), "ee", base="free-flyer")
    assert robot.base == "free-flyer" and robot.n_joints == 3
    with pytest.raises(UrdfError, match="locked_joints"):
        load_robot("ffsm_planar4.urdf", "ee", locked_joints={"joint1": 0.0})


def test_configuration_round_trip(tmp_path, urdf_text):
    robot = load_spatial_robot(_write(tmp_path, urdf_text), "ee")
    s = np.array([0.1, -0.3, 0.2])
    q = robot.configuration([1.0, 2.0, 3.0, *s], [0.1, 0.2, 0.3])
    from ffsm_pin.attitude import mrp

    assert np.allclose(mrp.from_quaternion(q[3:7]), s, atol=1e-15)
    with pytest.raises(ParameterError, match="expected 3 joint angles"):
        robot.configuration([0, 0, 0, 0, 0, 0], [0.0])


def test_panda_with_fingers_locked():
    robot = load_spatial_robot("example-robot-data:panda", "panda_hand", locked_joints=PANDA_LOCK)
    assert robot.n_joints == 7
    assert robot.joint_names == tuple(f"panda_joint{i}" for i in range(1, 8))
    # the locked fingers are merged into the last body: total mass of every link of the URDF
    full = pin.buildModelFromUrdf(str(robot.urdf_path))
    assert robot.geometry.total_mass == pytest.approx(
        sum(full.inertias[j].mass for j in range(full.njoints)), rel=1e-12
    )
    # package:// mesh paths resolve under the package dirs (for the replay)
    mesh = re.search(r'filename="package://([^"]+)"', robot.urdf_xml).group(1)
    assert any((d / mesh).is_file() for d in robot.package_dirs)


def test_ur5_loads():
    robot = load_spatial_robot("example-robot-data:ur5", "ee_link")
    assert robot.n_joints == 6
    # the URDF's root is a massless 'world' link fixed to 'base_link' (4 kg): one body
    assert robot.body_names[0] == "world"
    assert robot.geometry.masses[0] == pytest.approx(4.0, rel=1e-15)


def test_panda_without_locks_names_the_joints():
    with pytest.raises(UnsupportedJointError, match="panda_finger_joint1.*panda_finger_joint2"):
        load_spatial_robot("example-robot-data:panda", "panda_hand")
    with pytest.raises(FrameNotFoundError, match="end effector 'panda_hand'"):
        load_spatial_robot("example-robot-data:panda", "hand", locked_joints=PANDA_LOCK)


@pytest.mark.parametrize("name", sorted(EXAMPLE_ROBOTS))
def test_every_listed_example_robot_loads(name):
    """Each name of the table loads with its suggested end effector and locks, as a serial
    chain on a free-flyer root."""
    import warnings as w

    _, ee, locks = EXAMPLE_ROBOTS[name]
    with w.catch_warnings():
        w.simplefilter("ignore")  # continuous joints (kinova) are reported, not refused
        robot = load_spatial_robot(
            f"example-robot-data:{name}", ee, locked_joints=dict.fromkeys(locks, 0.0)
        )
    assert robot.n_joints >= 6
    assert robot.geometry.ee_body == robot.n_joints  # the end effector is on the last body


def test_unknown_example_robot_lists_names():
    with pytest.raises(RobotFileError, match="did you mean 'panda'.*'ur5'") as exc:
        load_spatial_robot("example-robot-data:pandaa", "panda_hand")
    for name in EXAMPLE_ROBOTS:
        assert repr(name) in str(exc.value)


def test_satellite_mass_and_inertia():
    """The satellite becomes body 0 together with the arm's root link: total mass adds up and
    body 0's spatial inertia is the satellite's plus the root link's moved by the mount."""
    sat = Satellite(
        mass=400.0,
        inertia=(60.0, 70.0, 50.0, 1.0, 0.5, -0.3),
        size=(1.2, 1.0, 0.8),
        mount_xyz=(0.1, -0.2, 0.4),
        mount_rpy=(0.0, 0.2, 0.3),
    )
    arm = load_spatial_robot("example-robot-data:ur5", "ee_link")
    both = load_spatial_robot("example-robot-data:ur5", "ee_link", satellite=sat)
    assert both.geometry.total_mass == pytest.approx(arm.geometry.total_mass + 400.0, rel=1e-14)
    assert both.body_names[0] == "satellite" and both.n_joints == arm.n_joints
    mount = pin.SE3(pin.rpy.rpyToMatrix(*sat.mount_rpy), np.array(sat.mount_xyz))
    expected = pin.Inertia(400.0, np.zeros(3), sat.inertia_matrix()) + mount.act(
        arm.model.inertias[1]
    )
    got = both.model.inertias[1]
    assert np.abs(got.matrix() - expected.matrix()).max() < 1e-12 * np.abs(expected.matrix()).max()
    # the arm hangs off the satellite at the mount
    assert np.allclose(
        both.model.jointPlacements[2].homogeneous,
        (mount * arm.model.jointPlacements[2]).homogeneous,
        atol=1e-14,
    )
    # dict form, unknown keys named
    Satellite.from_mapping({"mass": 100.0})
    with pytest.raises(ParameterError, match="unknown key 'mas' \\(did you mean 'mass'\\?\\)"):
        Satellite.from_mapping({"mas": 100.0})


# ---------------------------------------------------------------------------- bad input
def _replace_joint(text, name, new_type):
    return text.replace(
        f'<joint name="{name}" type="revolute">', f'<joint name="{name}" type="{new_type}">'
    )


def test_prismatic_joint_named(tmp_path, urdf_text):
    text = _replace_joint(urdf_text, "joint2", "prismatic")
    with pytest.raises(UnsupportedJointError, match="'joint2' is prismatic"):
        load_spatial_robot(_write(tmp_path, text), "ee")


def test_planar_joint_named(tmp_path, urdf_text):
    text = _replace_joint(urdf_text, "joint3", "planar")
    with pytest.raises(UnsupportedJointError, match="'joint3' is planar"):
        load_spatial_robot(_write(tmp_path, text), "ee")


def test_prismatic_joint_can_be_locked(tmp_path, urdf_text):
    text = _replace_joint(urdf_text, "joint3", "prismatic")
    robot = load_spatial_robot(_write(tmp_path, text), "ee", locked_joints={"joint3": 0.1})
    assert robot.n_joints == 2 and robot.locked_joints == {"joint3": 0.1}


def test_unlocked_branch_named(tmp_path, urdf_text):
    branch = (
        '  <link name="side"><inertial><mass value="1.0"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>\n'
        '  <joint name="side_joint" type="revolute"><parent link="link1"/><child link="side"/>'
        '<axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n'
        "</robot>"
    )
    text = urdf_text.replace("</robot>", branch)
    path = _write(tmp_path, text)
    with pytest.raises(UnsupportedJointError, match="locked_joints: 'side_joint'"):
        load_spatial_robot(path, "ee")
    assert load_spatial_robot(path, "ee", locked_joints={"side_joint": 0.0}).n_joints == 3


@pytest.mark.parametrize(
    ("inertia", "mass", "match"),
    [
        ('ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.02"', "0.0", "mass 0.0"),
        ('ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"', "2.0", "positive definite"),
        ('ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.05"', "2.0", "triangle"),
    ],
)
def test_non_physical_inertia_named(tmp_path, urdf_text, inertia, mass, match):
    old = re.search(r'<link name="link3">.*?</inertial>', urdf_text, re.S).group(0)
    new = re.sub(r"<inertia [^>]*/>", f"<inertia {inertia}/>", old)
    new = re.sub(r'<mass value="[^"]*"/>', f'<mass value="{mass}"/>', new)
    with pytest.raises(InertiaError, match=f"'link3'.*{match}"):
        load_spatial_robot(_write(tmp_path, urdf_text.replace(old, new)), "ee")


def test_two_roots_named(tmp_path, urdf_text):
    text = urdf_text.replace("</robot>", '  <link name="floating_debris"/>\n</robot>')
    with pytest.raises(UrdfError, match="single root link.*'floating_debris'"):
        load_spatial_robot(_write(tmp_path, text), "ee")


def test_end_effector_not_found(tmp_path, urdf_text):
    with pytest.raises(FrameNotFoundError, match="'ef' not found.*did you mean 'ee'"):
        load_spatial_robot(_write(tmp_path, urdf_text), "ef")
    with pytest.raises(FrameNotFoundError, match="attached to the base"):
        load_spatial_robot(_write(tmp_path, urdf_text), "base_link")


def test_unknown_locked_joint(tmp_path, urdf_text):
    with pytest.raises(UrdfError, match="locked joint 'joint9' not found.*'joint1'"):
        load_spatial_robot(_write(tmp_path, urdf_text), "ee", locked_joints={"joint9": 0.0})


def test_continuous_joints_accepted_with_warning(tmp_path, urdf_text):
    text = _replace_joint(urdf_text, "joint1", "continuous")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_spatial_robot(_write(tmp_path, text), "ee")
    assert robot.n_joints == 3
    assert any("'joint1'" in str(w.message) for w in caught)


def test_massless_root_suggests_a_satellite(tmp_path, urdf_text):
    """An arm-only URDF whose root link is massless (a 'world' link) cannot float by itself."""
    text = urdf_text.replace(
        '<link name="base_link">',
        '<link name="world"/>\n  <joint name="world_joint" type="revolute"><parent link="world"/>'
        '<child link="base_link"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n  <link name="base_link">',
    )
    path = _write(tmp_path, text)
    with pytest.raises(InertiaError, match="'world' has mass 0.0.*add a satellite"):
        load_spatial_robot(path, "ee")
    robot = load_spatial_robot(path, "ee", satellite=Satellite(mass=100.0))
    assert robot.n_joints == 4 and robot.body_names[0] == "satellite"


def test_example_robot_data_folder_is_found_once_per_installation(tmp_path, monkeypatch):
    """The share folder is looked up in the distribution's file list once per process and
    installation (site folder, version): the cached folder equals a fresh look-up, is used
    under its own key only, and is looked for again when it no longer holds the robots."""
    import importlib.metadata

    from ffsm_pin.robot import urdf

    monkeypatch.setattr(urdf, "_ERD_SHARE", {})
    fresh = urdf.example_robot_data_dir()
    dist = importlib.metadata.distribution("example-robot-data")
    key = (str(dist.locate_file("")), str(dist.version))
    if not urdf._ERD_SHARE:  # an older release: its module names the folder, nothing cached
        pytest.skip("example-robot-data's module gives its folder")
    assert urdf._ERD_SHARE == {key: fresh} and (fresh / "robots" / urdf._ERD_PANDA).is_file()
    assert urdf.example_robot_data_dir() == fresh
    decoy = tmp_path / "share"
    (decoy / "robots" / urdf._ERD_PANDA).parent.mkdir(parents=True)
    (decoy / "robots" / urdf._ERD_PANDA).write_text("<robot/>")
    urdf._ERD_SHARE.clear()
    urdf._ERD_SHARE[(key[0], "0.0.0")] = decoy  # another version's: not this installation's
    assert urdf.example_robot_data_dir() == fresh
    urdf._ERD_SHARE[key] = decoy  # the key's entry is what a second look-up returns
    assert urdf.example_robot_data_dir() == decoy
    (decoy / "robots" / urdf._ERD_PANDA).unlink()  # no longer holds the robots: looked for
    assert urdf.example_robot_data_dir() == fresh
    assert urdf._ERD_SHARE[key] == fresh
