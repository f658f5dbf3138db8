"""Replay a recorded run in meshcat: a self-contained HTML file, or a live server.

:func:`write_replay_html` writes meshcat's *static HTML* (the viewer's JavaScript inlined, the
scene and a :class:`meshcat.animation.Animation` embedded as base64 msgpack), so the file opens
from disk in any browser with no server and no network; the page is recorded in-process by
:class:`~ffsm_pin.sim.scene_recorder.SceneRecorder`.

:func:`serve_replay` starts meshcat's own server (a subprocess), sends the same scene and
animation, and returns the visualizer; :func:`close_visualizer` stops the server.

The scene (the robot's visual geometries, the base box, the reference and actual end-effector
paths) is :func:`ffsm_pin.sim.scene.build_scene`'s.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .meshes import ReplayWarning
from .result import RunResult
from .scene import DEFAULT_BASE_SIZE, MAX_MESH_MB, ROOT, _dims, _path_extent, build_scene
from .scene_recorder import SceneRecorder

if TYPE_CHECKING:
    from .scene import ReplayRobot

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's deprecated zmq.eventloop.ioloop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    from meshcat.animation import Animation

__all__ = [
    "ReplayWarning",
    "close_visualizer",
    "serve_replay",
    "write_replay_html",
]


def write_replay_html(
    robot: ReplayRobot,
    result: RunResult,
    path: str | Path,
    fps: float = 30.0,
    *,
    base_size: Sequence[float] = DEFAULT_BASE_SIZE,
    max_mesh_mb: float = MAX_MESH_MB,
) -> Path:
    """Write a self-contained meshcat animation of ``result`` to ``path`` (an .html file).

    Parameters
    ----------
    robot : ReplayRobot
        The robot drawn (:func:`~.scene.build_scene`).
    result : RunResult
        The run replayed.
    path : str or Path
        The .html file.
    fps : float
        Animation frames per second of simulated time (the run is decimated to it; playback
        is in real time).
    base_size : sequence of float
        Edges [m] of the box drawn at a root body without visuals when the robot gives no
        satellite size.
    max_mesh_mb : float
        Mesh data embedded as the files are up to this size [MB] (beyond it, DAE/OBJ meshes
        go in as binary STL).

    Returns
    -------
    Path
        The path written.
    """
    vis = meshcat.Visualizer(window=SceneRecorder())
    build_scene(vis, robot, result, fps=fps, base_size=base_size, max_mesh_mb=max_mesh_mb)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(vis.static_html(), encoding="utf-8")
    return path


def serve_replay(
    robot: ReplayRobot,
    result: RunResult | Sequence[RunResult],
    fps: float = 30.0,
    *,
    open_browser: bool = False,
    base_size: Sequence[float] = DEFAULT_BASE_SIZE,
    max_mesh_mb: float = MAX_MESH_MB,
) -> meshcat.Visualizer:
    """Start a live meshcat server, load the scene and play the animation.

    Several results are shown side by side (each offset along y). Prints the URL (meshcat
    does). Stop the server with :func:`close_visualizer` when done.

    Parameters
    ----------
    robot : ReplayRobot
        The robot drawn (:func:`~.scene.build_scene`).
    result : RunResult or sequence of RunResult
        The run or runs replayed.
    fps : float
        Animation frames per second of simulated time.
    open_browser : bool
        Open the viewer's URL in a browser.
    base_size : sequence of float
        Edges [m] of the box drawn at a root body without visuals.
    max_mesh_mb : float
        Mesh size budget [MB].

    Returns
    -------
    meshcat.Visualizer
        The live viewer.
    """
    results = [result] if isinstance(result, RunResult) else list(result)
    vis = meshcat.Visualizer()
    try:
        anim = Animation(default_framerate=fps)
        spacing = 0.0
        for k, res in enumerate(results):
            name = ROOT if len(results) == 1 else f"{ROOT}_{k + 1}_{_safe(res.scenario_name)}"
            spacing = max(spacing, _path_extent(res, _dims(robot.model)) + 4.0)
            build_scene(
                vis,
                robot,
                res,
                fps=fps,
                animation=anim,
                root=name,
                offset=(0.0, -k * spacing),
                base_size=base_size,
                max_mesh_mb=max_mesh_mb,
            )
        vis.set_animation(anim, play=True, repetitions=1)
        if open_browser:
            vis.open()
    except BaseException:
        close_visualizer(vis)
        raise
    return vis


def close_visualizer(vis: meshcat.Visualizer) -> None:
    """Stop the meshcat server subprocess started by ``meshcat.Visualizer()`` (if any)."""
    sock = getattr(vis.window, "zmq_socket", None)
    if sock is not None:
        sock.close(linger=0)
    proc = getattr(vis.window, "server_proc", None)
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)
