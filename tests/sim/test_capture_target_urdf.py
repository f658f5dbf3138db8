"""A one-body URDF as the ``[target]`` (issue 40): its link's inertial is the target; refusals."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario.file import builtin_path, load_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.setup import prepare

LINK = """
  <link name="{name}">
    <inertial>
      <origin xyz="0.02 -0.01 0.03" rpy="0.3 -0.2 0.5"/>
      <mass value="{mass}"/>
      <inertia ixx="0.6" ixy="0.0" ixz="0.0" iyy="0.9" iyz="0.0" izz="1.2"/>
    </inertial>
  </link>"""
JOINT = """
  <joint name="j" type="revolute">
    <parent link="tank"/><child link="lid"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>"""


def _urdf(tmp_path, mass: float = 25.0, second: bool = False, geometry: str = "") -> str:
    body = LINK.format(name="tank", mass=mass)
    body = body.replace("</inertial>", "</inertial>" + geometry)
    if second:
        body += LINK.format(name="lid", mass=1.0) + JOINT
    path = tmp_path / "tank.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<robot name="tank">{body}\n</robot>\n')
    return path.name


def _text(table: str) -> str:
    text = builtin_path("target-tumbling").read_text()
    return text[: text.index("\n[target]\n")] + "\n[target]\n" + table


TABLE = """urdf = "tank.urdf"
origin = "end-effector"
position = [1.5, 0.0, 0.0]
velocity = [-0.01, 0.0, 0.0]
angular_velocity = [0.02, 0.05, 0.03]
grasp_xyz = [-0.2, 0.0, 0.0]
"""


def _scenario(tmp_path, table: str = TABLE, **urdf):
    _urdf(tmp_path, **urdf)
    path = tmp_path / "scenario.toml"
    path.write_text(_text(table))
    return load_scenario(path)


def test_the_links_inertial_is_the_target(tmp_path):
    """Mass, CoM and the inertia about the CoM in the link frame: R diag(0.6, 0.9, 1.2) R^T
    with R the inertial's rpy; the saved scenario names the URDF by its absolute path."""
    sc = _scenario(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
    target = setup.target
    assert target is not None and target.size is None
    assert target.mass == 25.0
    assert np.array_equal(target.com, [0.02, -0.01, 0.03])
    R = pin.rpy.rpyToMatrix(0.3, -0.2, 0.5)
    assert np.abs(target.inertia - R @ np.diag([0.6, 0.9, 1.2]) @ R.T).max() < 1e-14
    assert np.array_equal(target.grasp.translation, [-0.2, 0.0, 0.0])
    saved = scenario_to_toml(sc)
    assert f'urdf = "{(tmp_path / "tank.urdf").resolve()}"' in saved
    again = scenario_from_toml(saved).target
    assert again is not None and sc.target is not None
    assert dataclasses.replace(again, urdf=sc.target.urdf, relative_to=sc.target.relative_to) == (
        sc.target
    )


def test_a_run_with_a_urdf_target_keeps_its_momentum(tmp_path):
    sc = dataclasses.replace(_scenario(tmp_path), duration=0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(prepare(sc))
    summary = result.summary()
    assert result.completed
    assert summary["target_drift_P"] < 1e-14 and summary["target_drift_L"] < 1e-13


BOX = '<{kind}>{origin}<geometry><box size="0.4 0.3 0.3"/></geometry></{kind}>'
MESH = '<visual><geometry><mesh filename="tank.stl"/></geometry></visual>'


@pytest.mark.parametrize(
    "geometry, size",
    [
        (BOX.format(kind="collision", origin=""), (0.4, 0.3, 0.3)),
        (BOX.format(kind="visual", origin='<origin xyz="0 0 0" rpy="0 0 0"/>'), (0.4, 0.3, 0.3)),
        (MESH + BOX.format(kind="collision", origin=""), (0.4, 0.3, 0.3)),  # the collision box
        (BOX.format(kind="collision", origin='<origin xyz="0.1 0 0"/>'), None),  # off centre
        (BOX.format(kind="visual", origin='<origin rpy="0 0 0.3"/>'), None),  # turned
        (MESH, None),
    ],
)
def test_a_centred_box_geometry_gives_the_target_its_size(tmp_path, geometry, size):
    """The link's first box (collision before visual), centred on the link frame with its
    axes, is the target's box: its size is the file's; other geometry gives no size."""
    sc = _scenario(tmp_path, geometry=geometry)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        target = prepare(dataclasses.replace(sc, duration=0.01)).target
    assert target is not None and target.size == size


def test_a_grasp_frame_outside_the_urdf_box_is_refused(tmp_path):
    """With a size from the URDF, the box's rule holds: a grasp frame 0.3 m from the centre
    of a 0.4 m box (face at 0.2 m) is one line naming the grasp frame."""
    table = TABLE.replace("grasp_xyz = [-0.2, 0.0, 0.0]", "grasp_xyz = [-0.3, 0.0, 0.0]")
    with pytest.raises(ScenarioError) as info:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prepare(_scenario(tmp_path, table, geometry=BOX.format(kind="collision", origin="")))
    msg = str(info.value)
    assert "\n" not in msg and "grasp" in msg, msg


BAD = {
    "two-links": (TABLE, {"second": True}, "target.urdf: "),
    "massless": (TABLE, {"mass": 0.0}, "target.urdf: "),
    "with-size": (TABLE + "size = [0.4, 0.3, 0.3]\n", {}, "target.size: not with target.urdf"),
    "with-mass": (TABLE + "mass = 4.0\n", {}, "target.mass: not with target.urdf"),
    "with-shape": (TABLE + 'shape = "box"\n', {}, "target.shape: not with target.urdf"),
    "no-body": (TABLE.replace('urdf = "tank.urdf"\n', ""), {}, "target.size: missing"),
    "no-mass": (
        TABLE.replace('urdf = "tank.urdf"\n', "size = [0.4, 0.3, 0.3]\n"),
        {},
        "target.mass: missing",
    ),
}


@pytest.mark.parametrize("what", list(BAD))
def test_bad_urdf_target_input_is_one_line(tmp_path, what):
    table, urdf, fragment = BAD[what]
    with pytest.raises(ScenarioError) as info:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prepare(_scenario(tmp_path, table, **urdf))
    msg = str(info.value)
    assert "\n" not in msg and fragment in msg, msg
    if what == "two-links":
        assert "2 links" in msg and "one body" in msg
