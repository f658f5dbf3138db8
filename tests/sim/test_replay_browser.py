"""Open replay.html in headless Chromium and check from a screenshot that the robot is drawn."""

from __future__ import annotations

import base64
import os
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
from synthetic_run import synthetic_result
from synthetic_spatial import free_flyer, panda, synthetic_spatial_result, with_satellite

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import umsgpack

from ffsm_pin.robot import load_robot
from ffsm_pin.sim.meshes import ReplayWarning
from ffsm_pin.sim.replay import write_replay_html
from ffsm_pin.sim.scene_recorder import SceneRecorder


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return "/usr/bin/chromium" if os.access("/usr/bin/chromium", os.X_OK) else None


CHROMIUM = _chromium()
pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        CHROMIUM is None,
        reason="headless Chromium not found (install the Debian package 'chromium'; .ci/run does)",
    ),
]


def screenshot(html: Path, png: Path, profile: Path) -> np.ndarray:
    cmd = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        f"--screenshot={png}",
        "--window-size=800,600",
        "--virtual-time-budget=5000",
        html.resolve().as_uri(),
    ]
    # A first Chromium start on a fresh machine, beside a test compiling on the other core
    # (pytest -n auto), once took over 120 s; a start that hangs is retried once with a new
    # profile. The timeout bounds the wait, it is no check of speed.
    for attempt in (1, 2):
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
            break
        except subprocess.TimeoutExpired:
            if attempt == 2:
                pytest.fail("headless Chromium did not finish within 180 s, twice")
            cmd[cmd.index(f"--user-data-dir={profile}")] = f"--user-data-dir={profile}-retry"
    assert png.is_file(), f"no screenshot; chromium said: {proc.stderr[-2000:]}"
    return matplotlib.image.imread(png)[..., :3]


def camera_commands(html: str) -> list[dict]:
    blobs = re.findall(r'base64,([A-Za-z0-9+/=]+)"', html)
    cmds = [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]
    return [c for c in cmds if c.get("path", "").startswith("/Cameras")]


def empty_scene(replay: Path, path: Path) -> Path:
    """An empty meshcat scene with the camera of ``replay``, written the same way."""
    vis = meshcat.Visualizer(window=SceneRecorder())
    for c in camera_commands(replay.read_text()):
        if c["type"] == "set_property":
            vis[c["path"]].set_property(c["property"], c["value"])
        elif c["type"] == "set_transform":
            vis[c["path"]].set_transform(np.array(c["matrix"]).reshape(4, 4).T)
    path.write_text(vis.static_html())
    return path


def gold(img: np.ndarray) -> np.ndarray:
    """Pixels of the gold base box (rgba 0.85 0.7 0.25), lit or in shade."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r > 0.5) & (g > 0.35) & (b < 0.35) & (r - b > 0.3)


def test_robot_is_drawn(tmp_path):
    robot = load_robot("ffsm_planar4.urdf")
    replay = write_replay_html(robot, synthetic_result(duration=3.0, dt=1e-3), tmp_path / "r.html")
    empty = empty_scene(replay, tmp_path / "empty.html")

    shot = screenshot(replay, tmp_path / "replay.png", tmp_path / "profile1")
    blank = screenshot(empty, tmp_path / "empty.png", tmp_path / "profile2")
    assert shot.shape == blank.shape == (600, 800, 3)

    changed = np.abs(shot - blank).max(axis=2) > 0.1
    assert changed.mean() > 0.005, f"only {changed.mean():.2%} of the pixels differ"

    # the gold base box is visible only in the replay
    assert gold(shot).sum() > 200, "the robot's base is not in the picture"
    assert gold(blank).sum() < 50  # (a few antialiased pixels of the axes triad)


def test_spatial_robot_with_meshes_is_drawn(tmp_path):
    """Panda (DAE meshes) on a satellite box, free-flyer root, opened from file://."""
    robot = with_satellite(panda(), size=(0.6, 0.6, 0.6))
    result = synthetic_spatial_result(robot, "panda_hand_tcp", duration=2.0, dt=1e-2)
    replay = write_replay_html(robot, result, tmp_path / "spatial.html")
    empty = empty_scene(replay, tmp_path / "empty.html")

    shot = screenshot(replay, tmp_path / "spatial.png", tmp_path / "profile1")
    blank = screenshot(empty, tmp_path / "empty.png", tmp_path / "profile2")
    changed = np.abs(shot - blank).max(axis=2) > 0.1
    # (the robot and its 0.6 m box take about 2% of the view, framed with the whole motion)
    assert changed.mean() > 0.01, f"only {changed.mean():.2%} of the pixels differ"
    assert gold(shot).sum() > 2000, "the satellite box is not in the picture"
    assert gold(blank).sum() < 50
    # the arm: changed pixels that are neither gold nor the paths' green/red, mostly the
    # Panda's white and dark grey (its DAE materials)
    greyish = (np.ptp(shot, axis=2) < 0.12) & changed & ~gold(shot)
    assert greyish.sum() > 1500, f"only {greyish.sum()} grey arm pixels"


def test_collada_meshes_are_drawn_like_the_stl_collision_meshes(tmp_path):
    """Panda's visual DAE files (Z-up Collada, read by three.js's ColladaLoader) and its STL
    collision meshes (no axis convention) cover the same pixels: the DAE orientation and
    units are right."""
    robot = panda()
    stl_xml = robot.urdf_xml.replace("meshes/visual/", "meshes/collision/").replace(".dae", ".stl")
    stl = free_flyer(robot.urdf_path, stl_xml, package_dirs=robot.package_dirs)
    result = synthetic_spatial_result(robot, "panda_hand_tcp", duration=0.0)
    dae_html = write_replay_html(robot, result, tmp_path / "dae.html")
    stl_html = write_replay_html(stl, result, tmp_path / "stl.html")
    with pytest.warns(ReplayWarning, match="binary STL"):  # the DAE files through trimesh
        compact_html = write_replay_html(robot, result, tmp_path / "compact.html", max_mesh_mb=1)
    empty = empty_scene(dae_html, tmp_path / "empty.html")
    blank = screenshot(empty, tmp_path / "empty.png", tmp_path / "p0")
    masks = []
    for html in (dae_html, stl_html, compact_html):
        shot = screenshot(html, html.with_suffix(".png"), tmp_path / f"p_{html.stem}")
        masks.append(np.abs(shot - blank).max(axis=2) > 0.1)

    def overlap(a, b):
        return (a & b).sum() / (a | b).sum()

    assert masks[0].sum() > 3000
    # collision meshes are simplified hulls of the visual ones: not pixel-identical
    assert overlap(masks[0], masks[1]) > 0.85, f"DAE vs STL: {overlap(masks[0], masks[1]):.0%}"
    # the same triangles as three.js's Collada reader, only in one colour a mesh
    assert overlap(masks[0], masks[2]) > 0.95, f"DAE vs compact: {overlap(masks[0], masks[2]):.0%}"
