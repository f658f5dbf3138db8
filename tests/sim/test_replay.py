"""The meshcat replay: a self-contained HTML animation, and the live server."""

from __future__ import annotations

import base64
import re
import warnings

import numpy as np
import pinocchio as pin
import pytest
from synthetic_run import synthetic_result

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat.visualizer
    import umsgpack

from ffsm_pin.robot import load_robot
from ffsm_pin.sim.replay import close_visualizer, serve_replay, write_replay_html
from ffsm_pin.sim.scene import frame_indices

_COMMAND = re.compile(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)')


@pytest.fixture(scope="module")
def robot():
    return load_robot("ffsm_planar4.urdf")


def commands(html: str) -> list[dict]:
    return [umsgpack.unpackb(base64.b64decode(b)) for b in _COMMAND.findall(html)]


def no_server(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("write_replay_html must not start a meshcat server")

    monkeypatch.setattr(meshcat.visualizer, "start_zmq_server_as_subprocess", refuse)


def test_html_is_self_contained_and_animates_the_robot(tmp_path, robot, monkeypatch):
    no_server(monkeypatch)
    result = synthetic_result(duration=4.0, dt=1e-3)
    path = write_replay_html(robot, result, tmp_path / "replay.html", fps=30)
    html = path.read_text()
    # self-contained: no external scripts, stylesheets or frames; the viewer is inlined
    assert not re.search(r"<script[^>]*\bsrc\s*=", html, re.I)
    assert not re.search(r"<(link|iframe|img)[^>]*(href|src)\s*=\s*[\"']?https?://", html, re.I)
    assert "new MeshCat.Viewer" in html and len(html) > 500_000

    cmds = commands(html)
    kinds = [c["type"] for c in cmds]
    assert kinds.count("set_animation") == 1
    objects = {c["path"]: c for c in cmds if c["type"] == "set_object"}
    visuals = pin.buildGeomFromUrdfString(robot.model, robot.urdf_xml, pin.GeometryType.VISUAL)
    for obj in visuals.geometryObjects:
        assert f"/meshcat/ffsm/robot/{obj.name}" in objects
    assert objects["/meshcat/ffsm/reference/path"]["object"]["object"]["type"] == "Line"
    assert "/meshcat/ffsm/ee_path" in objects

    anim = next(c for c in cmds if c["type"] == "set_animation")
    assert anim["options"]["play"] is True
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    for obj in visuals.geometryObjects:
        clip = clips[f"/meshcat/ffsm/robot/{obj.name}"]
        assert clip["fps"] == 30
        tracks = {t["name"]: t["keys"] for t in clip["tracks"]}
        assert set(tracks) == {".position", ".quaternion"}
        assert len(tracks[".position"]) == 4 * 30 + 1  # 4 s at 30 frames per second
    # the links really move: the last link's position changes over the run
    keys = {t["name"]: t["keys"] for t in clips["/meshcat/ffsm/robot/link4_0"]["tracks"]}
    pos = np.array([k["value"] for k in keys[".position"]])
    assert np.ptp(pos[:, :2], axis=0).max() > 0.1


def test_frame_positions_match_pinocchio(tmp_path, robot):
    result = synthetic_result(duration=1.0, dt=1e-3)
    html = write_replay_html(robot, result, tmp_path / "r.html", fps=10).read_text()
    anim = next(c for c in commands(html) if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"].endswith("/ee_link_0"))
    keys = next(t["keys"] for t in clip["tracks"] if t["name"] == ".position")
    data = robot.model.createData()
    q = result["q"][500]  # t = 0.5 s is frame 5 at 10 fps
    pin.framesForwardKinematics(robot.model, data, q)
    ee = data.oMf[robot.model.getFrameId("ee")].translation
    assert np.allclose(keys[5]["value"], ee, atol=1e-5)  # inertial coordinates
    # the whole scene is shifted (statically) so that the camera looks at its centre
    root = next(
        c for c in commands(html) if c["type"] == "set_transform" and c["path"] == "/meshcat/ffsm"
    )
    shift = np.array(root["matrix"]).reshape(4, 4).T  # meshcat sends column-major
    assert np.allclose(shift[:3, :3], np.eye(3)) and np.linalg.norm(shift[:2, 3]) > 0


def test_diverged_run_replays_up_to_the_last_finite_sample(tmp_path, robot):
    result = synthetic_result(duration=2.0, dt=1e-3, completed=False)
    result.signals["q"][-300:] = np.nan
    html = write_replay_html(robot, result, tmp_path / "r.html").read_text()
    anim = next(c for c in commands(html) if c["type"] == "set_animation")
    keys = anim["animations"][0]["clip"]["tracks"][0]["keys"]
    assert all(np.all(np.isfinite(k["value"])) for k in keys)
    assert len(keys) < 2 * 30 + 1


def test_frame_indices():
    t = np.arange(0, 3001) * 1e-3
    idx = frame_indices(t, 30)
    assert idx[0] == 0 and idx[-1] == 3000 and len(idx) == 91
    assert np.allclose(t[idx], np.arange(91) / 30, atol=5e-4)
    coarse = np.arange(0, 11) * 0.5  # fewer samples than frames: no duplicates
    assert list(frame_indices(coarse, 30)) == list(range(11))
    assert len(frame_indices(np.zeros(0), 30)) == 0


def test_live_server_starts_and_stops(robot):
    result = synthetic_result(duration=1.0, dt=1e-2)
    vis = serve_replay(robot, [result, synthetic_result(duration=1.0, dt=1e-2, phase=1.0)])
    proc = vis.window.server_proc
    try:
        assert vis.url().startswith("http://")
        assert proc.poll() is None
    finally:
        close_visualizer(vis)
    assert proc.poll() is not None  # no stray server process


def test_every_planar_visual_is_at_its_pinocchio_placement(tmp_path, robot):
    """Node transforms are Pinocchio's oMg; the cylinders' axis change is in their own matrix."""
    result = synthetic_result(duration=1.0, dt=1e-3)
    cmds = commands(write_replay_html(robot, result, tmp_path / "r.html", fps=10).read_text())
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    objects = {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}
    visuals = pin.buildGeomFromUrdfString(robot.model, robot.urdf_xml, pin.GeometryType.VISUAL)
    data, gdata = robot.model.createData(), pin.GeometryData(visuals)
    q = result["q"][700]  # t = 0.7 s is frame 7 at 10 fps
    pin.forwardKinematics(robot.model, data, q)
    pin.updateGeometryPlacements(robot.model, data, visuals, gdata)
    kinds = set()
    for obj, placement in zip(visuals.geometryObjects, gdata.oMg, strict=True):
        path = f"/meshcat/ffsm/robot/{obj.name}"
        tracks = {t["name"]: t["keys"] for t in clips[path]["tracks"]}
        x, y, z, w = tracks[".quaternion"][7]["value"]
        rot = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
        assert np.allclose(tracks[".position"][7]["value"], placement.translation, atol=1e-5)
        assert np.allclose(rot, placement.rotation, atol=1e-5)
        kind = type(obj.geometry).__name__
        kinds.add(kind)
        own = np.array(objects[path]["object"]["matrix"]).reshape(4, 4).T  # column-major
        assert np.allclose(own, np.eye(4))  # (cylinders: tests/sim/test_replay_spatial.py)
    assert kinds == {"Box", "Sphere"}
    # the planar base has a visual of its own: no extra base box
    assert "/meshcat/ffsm/robot/base_box" not in objects


def test_keys_are_at_the_samples_times_when_recorded_coarser_than_fps(tmp_path, robot):
    result = synthetic_result(duration=2.0, dt=0.1)  # 10 samples per second, 30 fps
    cmds = commands(write_replay_html(robot, result, tmp_path / "r.html", fps=30).read_text())
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clip = anim["animations"][0]["clip"]
    keys = next(t["keys"] for t in clip["tracks"] if t["name"] == ".position")
    times = np.array([k["time"] for k in keys]) / clip["fps"]
    assert np.allclose(times, result["t"], atol=1e-9)  # real-time playback, not 3x faster
