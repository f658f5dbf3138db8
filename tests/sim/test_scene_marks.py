"""The replay's marks of a capture and of the wheels (ffsm_pin/sim/scene_marks.py): the two
grasp frames' triads and the arrow of the wheels' stored momentum, read back from the static
HTML's meshcat commands and checked against Pinocchio's frames, the recorded target pose and
R_b A h computed here."""

from __future__ import annotations

import base64
import dataclasses
import re
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.replay import write_replay_html
from ffsm_pin.sim.scene_marks import ARROW_LENGTH, GRASP_HAND, GRASP_TARGET, WHEEL_MOMENTUM
from ffsm_pin.sim.setup import prepare

FPS = 10
HAND_RPY = (0.1, -0.2, 0.3)  # [rad]: turns the hand's triad, not its origin (the capture's)
TAU_W = np.array([0.02, 0.01, -0.02])  # [N m], constant wheel torques


class _WheelCommand:
    """The run's controller with a constant wheel torque (the optional hook)."""

    def __init__(self, inner) -> None:
        self.inner = inner

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def wheel_torque(self, meas):
        return TAU_W


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    """The 'capture' case for 3.3 s (captured at 3.06 s), a hand rotation, three wheels."""
    text = re.sub(
        r"^\[capture\]$",
        f"[capture]\nhand_rpy = {list(HAND_RPY)}",
        builtin_path("capture").read_text(),
        flags=re.M,
    )
    sc = scenario_from_toml(text + "\n[robot.satellite.wheels]\ninertia = 0.05\n")
    assert sc.target.capture.hand_rpy == HAND_RPY
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(dataclasses.replace(sc, duration=3.3))
    setup.controller = _WheelCommand(setup.controller)
    result = simulate(setup)
    assert result.capture.captured
    html = write_replay_html(setup.robot, result, tmp_path_factory.mktemp("r") / "r.html", FPS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import umsgpack
    found = re.findall(
        r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html.read_text()
    )
    return setup, result, [umsgpack.unpackb(base64.b64decode(b)) for b in found]


def _keyed(cmds, name):
    """{frame: 4x4 placement} and {frame: scale} of a node's animation tracks."""
    path = f"/meshcat/ffsm/{name}"
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"] == path)
    tracks = {
        tr["name"]: {k["time"]: np.array(k["value"]) for k in tr["keys"]} for tr in clip["tracks"]
    }
    out = {}
    for frame, pos in tracks[".position"].items():
        x, y, z, w = tracks[".quaternion"][frame]
        out[frame] = pin.SE3(pin.Quaternion(w, x, y, z).matrix(), pos).homogeneous
    return out, tracks.get(".scale", {})


def _row(result, frame):
    return int(np.argmin(np.abs(result["t"] - frame / FPS)))


def test_the_grasp_triads_are_the_hands_and_the_targets_grasp_frames(replay):
    """grasp_target: the recorded target pose times the target's grasp; grasp_hand: Pinocchio's
    end-effector frame of the recorded q times hand_rpy. From the capture on the two are welded:
    origins within the position tolerance, their relative placement constant."""
    setup, result, cmds = replay
    objects = {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}
    for name in (GRASP_HAND, GRASP_TARGET):
        assert objects[f"/meshcat/ffsm/{name}"]["object"]["type"] == "LineSegments"
    model, data = setup.robot.model, setup.robot.model.createData()
    hand_offset = pin.SE3(pin.rpy.rpyToMatrix(*HAND_RPY), np.zeros(3))
    hand, _ = _keyed(cmds, GRASP_HAND)
    target, _ = _keyed(cmds, GRASP_TARGET)
    assert set(hand) == set(target) and len(hand) == 34  # frames 0 .. 3.3 s at 10 per s
    relative = []
    for frame in sorted(hand):
        i = _row(result, frame)
        pin.framesForwardKinematics(model, data, result["q"][i])
        expected_hand = (data.oMf[setup.robot.ee_frame_id] * hand_offset).homogeneous
        expected_target = (
            pin.XYZQUATToSE3(result["target_pose"][i]) * setup.target.grasp
        ).homogeneous
        assert np.abs(hand[frame] - expected_hand).max() < 1e-6  # (sent as float32)
        assert np.abs(target[frame] - expected_target).max() < 1e-6
        if result["t"][i] >= result.capture.time:
            gap = np.linalg.norm(hand[frame][:3, 3] - target[frame][:3, 3])
            assert gap <= setup.scenario.target.capture.tolerance_position
            relative.append(np.linalg.inv(hand[frame]) @ target[frame])
    assert len(relative) == 3
    assert np.abs(np.array(relative) - relative[0]).max() < 1e-6


def test_the_wheels_arrow_is_their_stored_momentum(replay):
    """wheel_momentum: a cylinder (axis y) from the bus origin along R_b A h (axes "xyz": A = I,
    h = tau t), its length ARROW_LENGTH |h| / max |h|, R_b from the recorded quaternion."""
    setup, result, cmds = replay
    objects = {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}
    assert objects[f"/meshcat/ffsm/{WHEEL_MOMENTUM}"]["geometries"][0]["type"] == (
        "CylinderGeometry"
    )
    placed, scales = _keyed(cmds, WHEEL_MOMENTUM)
    rows = {frame: _row(result, frame) for frame in placed}
    largest = max(np.linalg.norm(result["wheel_momentum"][i]) for i in rows.values())
    for frame, place in placed.items():
        i = rows[frame]
        q = result["q"][i]
        R_b = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().matrix()
        stored = R_b @ result["wheel_momentum"][i]
        length = ARROW_LENGTH * np.linalg.norm(stored) / largest
        assert abs(scales[frame][1] - max(length, 1e-6)) < 1e-6
        if frame == 0:  # (h = 0: a hidden arrow)
            continue
        np.testing.assert_allclose(place[:3, 1], stored / np.linalg.norm(stored), atol=1e-6)
        np.testing.assert_allclose(place[:3, 3] - 0.5 * length * place[:3, 1], q[:3], atol=1e-6)
    last = max(placed)
    assert scales[last][1] == pytest.approx(ARROW_LENGTH, rel=1e-6)  # (h grows as tau t)
