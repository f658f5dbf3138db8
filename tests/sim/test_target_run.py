"""A run with a ``[target]`` (issue 40, first slice): the built-in 'target-tumbling' case.

The target moves torque-free beside the robot, which does not touch it: its momentum is kept
to rounding, its pose agrees with an independent integration, the run records its pose and
twist and the replay draws it; bad input is one line and exit status 2."""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario.file import builtin_path, builtin_scenario
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.recording import recorder_shapes
from ffsm_pin.sim.setup import prepare
from ffsm_pin.sim.target import Target, TargetState
from ffsm_pin.sim.target_run import TARGET_SIGNALS, boxes_overlap, check_clear_of_bus

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import umsgpack

TUMBLING = builtin_path("target-tumbling").read_text()


@pytest.fixture(scope="module")
def run():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(builtin_scenario("target-tumbling"))
    return setup, simulate(setup)


def test_the_target_starts_where_the_file_puts_it(run):
    setup, _ = run
    sc = setup.scenario
    data = setup.robot.model.createData()
    pin.framesForwardKinematics(setup.robot.model, data, setup.q0)
    ee = data.oMf[setup.robot.model.getFrameId(sc.robot.end_effector)].translation
    state = setup.target_state
    assert np.allclose(state.pose.translation, ee + np.array(sc.target.position), atol=1e-12)
    assert np.allclose(state.pose.rotation, np.eye(3))
    assert state.velocity.tolist() == [-0.01, 0.0, 0.0]
    assert state.angular_velocity.tolist() == [0.02, 0.05, 0.03]
    a, b, c = 0.4, 0.3, 0.3
    box = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * 40.0 / 12
    assert np.allclose(setup.target.inertia, box, rtol=1e-15)


def test_the_run_records_the_target(run):
    setup, result = run
    assert result.completed and result.summary()["funnel_ok_b"] and result.summary()["funnel_ok_z"]
    n = len(result["t"])
    assert result["target_pose"].shape == (n, 7) and result["target_twist"].shape == (n, 6)
    assert np.allclose(np.linalg.norm(result["target_pose"][:, 3:], axis=1), 1.0, atol=1e-14)
    # the CoM drifts at its constant velocity
    p0 = setup.target_state.pose.translation
    expected = p0 + np.outer(result["t"], [-0.01, 0.0, 0.0])
    assert np.abs(result["target_pose"][:, :3] - expected).max() < 1e-12
    assert (result["target_twist"][:, :3] == [-0.01, 0.0, 0.0]).all()


def test_the_targets_momentum_is_kept_to_rounding(run):
    setup, result = run
    summary = result.summary()
    state, target = setup.target_state, setup.target
    P0 = np.linalg.norm(state.linear_momentum(target))
    L0 = np.linalg.norm(state.angular_momentum(target, about=np.zeros(3)))
    assert summary["target_drift_P"] / P0 < 1e-10
    assert summary["target_drift_L"] / L0 < 1e-10  # (measured 1e-16)
    # the angular momentum about the CoM, R I w, kept too (world frame)
    R = np.array([pin.XYZQUATToSE3(p).rotation for p in result["target_pose"]])
    L_com = np.einsum("rij,jk,rk->ri", R, np.array(target.inertia), result["target_twist"][:, 3:])
    L_c0 = state.angular_momentum(target)
    assert np.abs(L_com - L_c0).max() / np.linalg.norm(L_c0) < 1e-10


def _euler(inertia):
    I_inv = np.linalg.inv(inertia)

    def rhs(_t, y):
        qx, qy, qz, qw = y[3:7]
        w = y[7:]
        # dq/dt = q (x) (0, w) / 2, w in the body frame; quaternion (x, y, z, w)
        wx, wy, wz = w
        dq = 0.5 * np.array(
            [
                qw * wx + qy * wz - qz * wy,
                qw * wy + qz * wx - qx * wz,
                qw * wz + qx * wy - qy * wx,
                -qx * wx - qy * wy - qz * wz,
            ]
        )
        dw = I_inv @ np.cross(inertia @ w, w)
        return np.concatenate((np.zeros(3), dq, dw))

    return rhs


def test_the_pose_agrees_with_an_independent_integration(run):
    """scipy's DOP853 (rtol 1e-12) on Euler's equations and the quaternion kinematics; the
    CoM (the box's centre) moves at its constant velocity."""
    setup, result = run
    state, target = setup.target_state, setup.target
    t = np.asarray(result["t"])
    y0 = np.concatenate((np.zeros(3), pin.SE3ToXYZQUAT(state.pose)[3:], state.angular_velocity))
    sol = solve_ivp(
        _euler(np.array(target.inertia)), (0.0, t[-1]), y0, method="DOP853",
        t_eval=t, rtol=1e-12, atol=1e-14,
    )  # fmt: skip
    assert sol.success
    q_ref = sol.y[3:7].T / np.linalg.norm(sol.y[3:7].T, axis=1)[:, None]
    R_ref = np.array([pin.Quaternion(q[3], q[0], q[1], q[2]).toRotationMatrix() for q in q_ref])
    R = np.array([pin.XYZQUATToSE3(p).rotation for p in result["target_pose"]])
    assert np.abs(R - R_ref).max() < 1e-8
    assert np.abs(result["target_twist"][:, 3:] - sol.y[7:].T).max() < 1e-8
    p_ref = state.pose.translation + np.outer(t, state.velocity)
    assert np.abs(result["target_pose"][:, :3] - p_ref).max() < 1e-8
    assert np.abs(R[-1] - R[0]).max() > 0.1  # it did tumble


def _commands(html: str) -> list[dict]:
    found = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in found]


def test_the_replay_draws_the_target_at_its_recorded_poses(run, tmp_path):
    from ffsm_pin.sim.replay import write_replay_html

    setup, result = run
    html = write_replay_html(setup.robot, result, tmp_path / "r.html", fps=2).read_text()
    cmds = _commands(html)
    objects = {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}
    box = objects["/meshcat/ffsm/target_box"]["geometries"][0]
    assert box["type"] == "BoxGeometry"
    assert [box["width"], box["height"], box["depth"]] == pytest.approx([0.4, 0.3, 0.3])
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"] == "/meshcat/ffsm/target_box")
    tracks = {tr["name"]: tr["keys"] for tr in clip["tracks"]}
    t = np.asarray(result["t"])
    assert len(tracks[".position"]) == 2 * 10 + 1
    for key_pos, key_quat in zip(tracks[".position"], tracks[".quaternion"], strict=True):
        row = int(np.argmin(np.abs(t - key_pos["time"] / 2)))
        pose = result["target_pose"][row]
        assert np.allclose(key_pos["value"], pose[:3], atol=1e-6)  # inertial coordinates
        x, y, z, w = key_quat["value"]
        rot = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
        assert np.allclose(rot, pin.XYZQUATToSE3(pose).rotation, atol=1e-6)


def test_a_run_without_a_target_records_what_it_did():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(builtin_scenario("spatial-realistic"))
    assert setup.target is None and setup.target_state is None
    assert not set(TARGET_SIGNALS) & set(recorder_shapes(setup))


# ------------------------------------------------------------------------------ the bus
def test_boxes_overlap_on_every_axis_kind():
    unit = pin.SE3.Identity()
    turned = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, np.pi / 4), np.zeros(3))
    at = lambda m, x: pin.SE3(m.rotation, np.array(x, float))  # noqa: E731
    cube = (1.0, 1.0, 1.0)
    assert boxes_overlap(unit, cube, at(unit, [0.99, 0, 0]), cube)
    assert not boxes_overlap(unit, cube, at(unit, [1.0, 0, 0]), cube)  # touching
    # a cube turned by 45 degrees reaches sqrt(2) / 2 along x
    reach = 0.5 + np.sqrt(2) / 2
    assert boxes_overlap(unit, cube, at(turned, [reach - 0.01, 0, 0]), cube)
    assert not boxes_overlap(unit, cube, at(turned, [reach + 0.01, 0, 0]), cube)
    # edge against edge: only a cross-product axis separates them
    tilted = pin.SE3(pin.rpy.rpyToMatrix(np.pi / 4, 0.0, np.pi / 4), np.zeros(3))
    d = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    far = [boxes_overlap(unit, cube, at(tilted, s * d), cube) for s in (0.9, 1.3)]
    assert far == [True, False]


def test_a_target_over_the_root_origin_is_refused_when_the_bus_size_is_unknown(run):
    setup, _ = run
    target = Target.box((0.4, 0.3, 0.3), 40.0)
    data = setup.robot.model.createData()
    pin.forwardKinematics(setup.robot.model, data, setup.q0)
    root = data.oMi[1].translation
    on_root = TargetState.from_rpy(root + [0.1, 0.0, 0.0], (0.0, 0.0, 0.0))
    with pytest.raises(ScenarioError, match="holds the robot's root frame origin"):
        check_clear_of_bus(target, on_root, setup.robot, setup.q0, None)
    beside = TargetState.from_rpy(root + [0.25, 0.0, 0.0], (0.0, 0.0, 0.0))
    check_clear_of_bus(target, beside, setup.robot, setup.q0, None)
    # with the bus's 0.7 m cube known, the same target overlaps it
    with pytest.raises(ScenarioError, match="overlaps the bus"):
        check_clear_of_bus(target, beside, setup.robot, setup.q0, (0.7, 0.7, 0.7))


# ------------------------------------------------------------------------------ the CLI
def _sim(tmp_path, text: str) -> subprocess.CompletedProcess:
    path = tmp_path / "s.toml"
    path.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(path), "--no-plots",
         "--no-html", "--out", "o"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    return proc


def _replaced(key: str, line: str) -> str:
    head, table = TUMBLING.split("\n[target]\n")
    table, n = re.subn(rf"(?m)^{key} = .*$", line, table)
    assert n == 1, key
    return f"{head}\n[target]\n{table}"


BAD = {
    "shape": (_replaced("shape", 'shape = "sphere"'), "target.shape", "valid choices: 'box'"),
    "mass": (_replaced("mass", "mass = -1.0"), "target.mass", "must be > 0"),
    "size": (_replaced("size", "size = [0.4, 0.0, 0.3]"), "target.size[1]", "> 0"),
    "inertia": (
        _replaced("mass", "mass = 40.0\ninertia = [0.1, 0.1, 0.3, 0.0, 0.0, 0.0]"),
        "target.inertia",
        "triangle inequality",
    ),
    "grasp": (
        _replaced("grasp_xyz", "grasp_xyz = [-0.3, 0.0, 0.0]"),
        "target.grasp_xyz",
        "outside",
    ),
    "origin": (_replaced("origin", 'origin = "hand"'), "target.origin", "'end-effector'"),
    "bus": (
        _replaced("position", "position = [-0.3, 0.0, -0.2]"),
        "target.position",
        "overlaps the bus",
    ),
    "planar": (
        builtin_path("case1").read_text() + "\n[target]\n" + TUMBLING.split("\n[target]\n")[1],
        "target",
        "robot.base = 'free-flyer'",
    ),
}


@pytest.mark.parametrize("what", list(BAD))
def test_bad_input_is_one_line_and_status_2(tmp_path, what):
    text, key, fragment = BAD[what]
    proc = _sim(tmp_path, text)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, lines
    # (the scenario's own errors after the file's name, the bus's after "error: ")
    assert re.match(rf"error: (\S+s\.toml: )?{re.escape(key)}(?!\w)", lines[0]), lines[0]
    assert fragment in lines[0], lines[0]
    assert not (tmp_path / "o" / "summary.json").exists()


def test_the_builtin_case_runs_from_the_command_line(tmp_path):
    """``--check`` passes; a short run writes the target's signals and summary keys."""
    check = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--check", "--case", "target-tumbling"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert check.returncode == 0, check.stderr
    text = TUMBLING.replace("duration = 10.0", "duration = 0.5")
    proc = _sim(tmp_path, text)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["target_drift_P"] == 0.0 and summary["target_drift_L"] < 1e-12
    with np.load(tmp_path / "o" / "trajectory.npz") as npz:
        assert npz["target_pose"].shape == (251, 7) and npz["target_twist"].shape == (251, 6)
