"""Scenario files for spatial robots (base = "free-flyer"): the keys of docs/cli.md, attitude
alternatives converted to MRPs, the initial state they describe (checked against Pinocchio's
centroidal momentum), and bad input refused before simulating with one line and exit 2."""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.errors import FfsmError
from ffsm_pin.robot import urdf_dir
from ffsm_pin.scenario.file import BUILTIN, builtin_path, builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import initial_state, prepare

SPATIAL_TEXT = builtin_path("spatial").read_text()


def _edit(text: str, key: str, value: str) -> str:
    """Replace the line ``key = ...`` (first occurrence) by ``key = value``."""
    new, n = re.subn(rf"(?m)^{re.escape(key)} = .*$", f"{key} = {value}", text, count=1)
    assert n == 1, key
    return new


def test_spatial_builtin_round_trips():
    sc = builtin_scenario("spatial")
    assert sc.robot.base == "free-flyer" and sc.reference.task == "position"
    assert dict(sc.robot.locked_joints) == {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}
    assert sc.robot.satellite is not None
    again = scenario_from_toml(scenario_to_toml(sc))
    for field in ("initial", "reference", "controller"):
        assert getattr(again, field) == getattr(sc, field), field
    assert again.robot.satellite == sc.robot.satellite
    assert again.robot.locked_joints == sc.robot.locked_joints


@pytest.mark.parametrize("kind", ["rpy", "quaternion"])
def test_attitude_alternatives_are_written_back_as_mrp(kind):
    """base_attitude_rpy / _quaternion describe the same rotation as the MRP they become."""
    sc = builtin_scenario("spatial")
    s = np.array(sc.initial.base_pose[3:])
    R = mrp.to_rotation(s)
    if kind == "rpy":
        value = pin.rpy.matrixToRpy(R).tolist()
    else:
        value = (-pin.Quaternion(R).coeffs()).tolist()  # the other sign: same rotation
    text = _edit(SPATIAL_TEXT, "base_pose", "[0.0, 0.0, 0.0]")
    text = text.replace(
        "com_at_origin = true", f"base_attitude_{kind} = {value}\ncom_at_origin = true"
    )
    alt = scenario_from_toml(text)
    np.testing.assert_allclose(alt.initial.base_pose[3:], s, atol=1e-12)
    saved = scenario_to_toml(alt)
    assert "base_attitude_" not in saved
    assert scenario_from_toml(saved).initial == alt.initial


def test_initial_state_has_the_requested_momentum():
    """com_velocity and angular_momentum (inertial, about the CoM) are what Pinocchio's
    centroidal momentum of the built state says; base_rate gives the base angular velocity."""
    sc = builtin_scenario("spatial")
    setup = prepare(sc)
    robot = setup.robot
    ini = sc.initial.__class__(
        base_pose=sc.initial.base_pose, joints=sc.initial.joints,
        joint_rates=(0.1, -0.2, 0.05, 0.1, 0.0, 0.2, -0.1), com_at_origin=True,
        com_velocity=(0.01, -0.02, 0.005), angular_momentum=(0.3, -0.1, 0.2),
    )  # fmt: skip
    q, v = initial_state(robot, ini)
    data = robot.model.createData()
    hg = pin.computeCentroidalMomentum(robot.model, data, q, v)
    np.testing.assert_allclose(hg.linear / robot.geometry.total_mass, ini.com_velocity, atol=1e-12)
    np.testing.assert_allclose(hg.angular, ini.angular_momentum, atol=1e-12)
    np.testing.assert_allclose(data.com[0], 0.0, atol=1e-12)
    rate = (0.02, 0.0, -0.01)
    ini2 = ini.__class__(
        base_pose=ini.base_pose, joints=ini.joints, joint_rates=ini.joint_rates,
        com_velocity=ini.com_velocity, base_rate=rate,
    )  # fmt: skip
    q, v = initial_state(robot, ini2)
    R0 = mrp.to_rotation(ini.base_pose[3:])
    np.testing.assert_allclose(R0 @ v[3:6], rate, atol=1e-14)
    hg = pin.computeCentroidalMomentum(robot.model, robot.model.createData(), q, v)
    np.testing.assert_allclose(hg.linear / robot.geometry.total_mass, ini.com_velocity, atol=1e-12)


def _six_components(text: str) -> str:
    """The pose task's 6 reference entries and funnel z arrays (one number each)."""
    entries = "ee = [\n" + "  { c = 0.0 },\n" * 6 + "]"
    text = re.sub(r"(?m)^ee = \[\n(?:.*\n)*?\]", entries, text)
    for key, value in (("rho_z0", "0.06"), ("rho_zinf", "0.01"), ("beta_z", "0.2"),
                       ("sigma_z", "0.8")):  # fmt: skip
        text = _edit(text, key, value)
    return text


BAD = {
    # the Panda has 7 joints; the pose task with attitude regulation needs 9
    "infeasible task": (
        lambda t: _six_components(_edit(t, "task", '"pose"')),
        ("at least 9 manipulator joints", "has 7"),
    ),
    "funnel length": (
        lambda t: _edit(t, "rho_b0", "[0.1, 0.1]"),
        ("controller.funnel.rho_b0", "2 values, expected 3"),
    ),
    "mrp beyond 1": (
        lambda t: _edit(t, "base_attitude", "[0.9, 0.5, 0.0]"),
        ("reference.base_attitude", "|s| = 1.03 > 1", "shadow"),
    ),
    "initial error outside the funnel": (
        lambda t: _edit(t, "rho_b0", "[0.02, 0.02, 0.02]").replace(
            "rho_binf = [0.01, 0.01, 0.01]", "rho_binf = [0.005, 0.005, 0.005]"
        ),
        ("initial base attitude error", "not strictly inside", "rho_b0"),
    ),
    "base pose length": (
        lambda t: _edit(t, "base_pose", "[0.0, 0.0, 0.0, 0.1]"),
        ("initial.base_pose", "4 values, expected 6"),
    ),
    # the paper's planar funnels are no default for a spatial task, even of the same size (3)
    "missing funnel key": (
        lambda t: re.sub(r"(?m)^rho_z0 = .*\n", "", t),
        ("controller.funnel.rho_z0", "missing", "no default"),
    ),
    "joint count": (
        lambda t: _edit(_edit(t, "joints", "[0.0, 0.0, 0.0]"), "joint_rates", "[0.0, 0.0, 0.0]"),
        ("initial.joints", "has 7 joints"),
    ),
}


@pytest.mark.parametrize("name", list(BAD))
def test_bad_spatial_input_is_one_line_exit_2(tmp_path, name):
    edit, fragments = BAD[name]
    path = tmp_path / "bad.toml"
    path.write_text(edit(SPATIAL_TEXT))
    out = str(tmp_path / "o")
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(path), "--out", out,
         "--no-plots", "--no-html"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def test_position_task_is_valid_for_planar_robots():
    """task = "position": 2 components (x, y) for a planar robot, funnel z of size 2."""
    text = builtin_path("case1").read_text()
    text = text.replace("[reference]", '[reference]\ntask = "position"')
    text = text.replace(
        "  { c = 0.03, cos = [[0.03, 0.3490658503988659], [0.05, 0.3333333333333333]] },\n", ""
    )
    for key, value in (("rho_z0", "[1.0, 1.0]"), ("rho_zinf", "[0.08, 0.08]"),
                       ("beta_z", "[0.22, 0.22]"), ("sigma_z", "[0.8, 0.8]")):  # fmt: skip
        text = _edit(text, key, value)
    sc = scenario_from_toml(text)
    assert sc.reference.task == "position" and len(sc.reference.ee) == 2
    setup = prepare(sc)
    # the compiled period serves the position task too (it fell back to numpy before)
    assert setup.n_task == 2 and setup.controller.law.backend == "numba"
    with pytest.raises(FfsmError, match="3 values, expected 2"):
        scenario_from_toml(_edit(text, "rho_z0", "[1.0, 1.0, 0.2]"))


@pytest.mark.parametrize(
    ("name", "scheme"),
    [("spatial-known-model", "known-model"), ("spatial-no-ppc", "no-ppc"),
     ("spatial-no-attitude", "no-attitude")],
)  # fmt: skip
def test_spatial_variants_differ_from_spatial_only_in_the_scheme(name, scheme):
    base, other = builtin_scenario("spatial"), builtin_scenario(name)
    assert other.controller.scheme == scheme
    lu_jia = dataclasses.replace(base.controller.lu_jia, scheme=scheme)
    assert other.controller == dataclasses.replace(base.controller, lu_jia=lu_jia)
    for field in ("robot", "initial", "reference", "duration", "dt", "performance"):
        assert getattr(other, field) == getattr(base, field), field


@pytest.mark.parametrize("name", [n for n in BUILTIN if n.startswith("spatial")])
def test_every_spatial_builtin_prepares(name):
    """Loads, builds the robot (locked fingers, satellite) and passes every pre-run check."""
    setup = prepare(builtin_scenario(name))
    n = 9 if name == "spatial-pose" else 7  # the pose task needs 6 + 3 joints
    assert setup.robot.n_joints == len(setup.scenario.initial.joints) == n
    assert setup.n_task == (6 if name == "spatial-pose" else 3)
    assert setup.scenario.duration >= 30.0


def test_spatial9_urdf_is_its_table():
    """The shipped 9-joint arm is exactly what ffsm_pin.robot.writer writes from its table."""
    import tomllib

    from ffsm_pin.robot.writer import chain_from_table, chain_to_urdf

    folder = urdf_dir()
    table = tomllib.loads((folder / "spatial9.toml").read_text())
    assert chain_to_urdf(chain_from_table(table)) == (folder / "spatial9.urdf").read_text()
