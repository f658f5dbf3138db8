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

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import umsgpack

from ffsm_pin.robot import load_robot
from ffsm_pin.sim.replay import SceneRecorder, write_replay_html


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
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("headless Chromium did not finish within 120 s")
    assert png.is_file(), f"no screenshot; chromium said: {proc.stderr[-2000:]}"
    return matplotlib.image.imread(png)[..., :3]


def camera_commands(html: str) -> list[dict]:
    blobs = re.findall(r'base64,([A-Za-z0-9+/=]+)"', html)
    cmds = [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]
    return [c for c in cmds if c.get("path", "").startswith("/Cameras")]


def test_robot_is_drawn(tmp_path):
    robot = load_robot("ffsm_planar4.urdf")
    replay = write_replay_html(robot, synthetic_result(duration=3.0, dt=1e-3), tmp_path / "r.html")

    # an empty meshcat scene with the same camera, written the same way
    vis = meshcat.Visualizer(window=SceneRecorder())
    for c in camera_commands(replay.read_text()):
        if c["type"] == "set_property":
            vis[c["path"]].set_property(c["property"], c["value"])
        elif c["type"] == "set_transform":
            vis[c["path"]].set_transform(np.array(c["matrix"]).reshape(4, 4).T)
    empty = tmp_path / "empty.html"
    empty.write_text(vis.static_html())

    shot = screenshot(replay, tmp_path / "replay.png", tmp_path / "profile1")
    blank = screenshot(empty, tmp_path / "empty.png", tmp_path / "profile2")
    assert shot.shape == blank.shape == (600, 800, 3)

    changed = np.abs(shot - blank).max(axis=2) > 0.1
    assert changed.mean() > 0.005, f"only {changed.mean():.2%} of the pixels differ"

    # the gold base box (rgba 0.85 0.7 0.25) is visible only in the replay
    def gold(img):
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        return (r > 0.5) & (g > 0.35) & (b < 0.35) & (r - b > 0.3)

    assert gold(shot).sum() > 200, "the robot's base is not in the picture"
    assert gold(blank).sum() < 50  # (a few antialiased pixels of the axes triad)
