"""Replay a recorded run in meshcat: a self-contained HTML file, or a live server.

:func:`write_replay_html` writes meshcat's *static HTML* (the viewer's JavaScript inlined, the
scene and a :class:`meshcat.animation.Animation` embedded as base64 msgpack), so the file opens
from disk in any browser with no server and no network. The scene is recorded in-process by a
stand-in for meshcat's ZMQ server (:class:`SceneRecorder`), which keeps the same scene tree
and writes the same HTML as ``Visualizer.static_html()``, without starting a subprocess.

:func:`serve_replay` starts meshcat's own server (a subprocess), sends the same scene and
animation, and returns the visualizer; :func:`close_visualizer` stops the server.

The scene: every visual geometry of the URDF (boxes, spheres, cylinders) moved per frame from
the recorded configuration ``q``, the end-effector reference path (green line) with a moving
target (green sphere), and the end-effector's actual path (red line).
"""

from __future__ import annotations

import base64
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..robot import FreeFloatingRobot
from .result import RunResult

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's deprecated zmq.eventloop.ioloop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import meshcat.geometry as mg
    import umsgpack
    from meshcat.animation import Animation
    from meshcat.servers.tree import SceneTree, find_node, walk

ROOT = "ffsm"  # all objects live under /meshcat/ffsm
_REFERENCE_COLOR = 0x22AA44
_PATH_COLOR = 0xCC2222


class SceneRecorder:
    """In-process stand-in for meshcat's ``ViewerWindow`` + ZMQ server.

    ``meshcat.Visualizer(window=SceneRecorder())`` accepts the usual calls (``set_object``,
    ``set_transform``, ``set_property``, ``set_animation``, ``delete``); they are kept in a
    scene tree exactly as meshcat's server keeps them, and :meth:`get_scene` (called by
    ``Visualizer.static_html()``) returns the self-contained HTML page.
    """

    web_url = None

    def __init__(self) -> None:
        self.tree = SceneTree()

    def send(self, command) -> None:
        data = command.lower()
        packed = umsgpack.packb(data)
        kind = data["type"]
        path = [p for p in data.get("path", "").split("/") if p]
        if kind == "delete":
            if path:
                parent = find_node(self.tree, path[:-1])
                parent.pop(path[-1], None)
            else:
                self.tree = SceneTree()
            return
        node = find_node(self.tree, path)
        if kind == "set_object":
            node.object, node.properties = packed, []
        elif kind == "set_transform":
            node.transform = packed
        elif kind == "set_property":
            node.properties.append(packed)
        elif kind == "set_animation":
            node.animation = packed
        else:  # pragma: no cover - only the commands above exist in meshcat 0.3
            raise ValueError(f"unsupported meshcat command {kind!r}")

    def get_scene(self) -> str:
        """The static HTML page (meshcat's viewer JavaScript inlined, commands embedded)."""
        commands = []
        for node in walk(self.tree):
            blobs = [node.object, *node.properties, node.transform, node.animation]
            commands += [_command_js(b) for b in blobs if b is not None]
        return _HTML.format(mainminjs=_viewer_js(), commands="".join(commands))

    def close(self) -> None:
        pass


def write_replay_html(
    robot: FreeFloatingRobot, result: RunResult, path: str | Path, fps: float = 30.0
) -> Path:
    """Write a self-contained meshcat animation of ``result`` to ``path`` (an .html file).

    fps: animation frames per second of simulated time (the run is decimated to it; playback
    is in real time). Returns the path written.
    """
    vis = meshcat.Visualizer(window=SceneRecorder())
    build_scene(vis, robot, result, fps=fps)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(vis.static_html(), encoding="utf-8")
    return path


def serve_replay(
    robot: FreeFloatingRobot,
    result: RunResult | Sequence[RunResult],
    fps: float = 30.0,
    *,
    open_browser: bool = False,
) -> meshcat.Visualizer:
    """Start a live meshcat server, load the scene and play the animation.

    Several results are shown side by side (each offset along y). Prints the URL (meshcat
    does). Stop the server with :func:`close_visualizer` when done.
    """
    results = [result] if isinstance(result, RunResult) else list(result)
    vis = meshcat.Visualizer()
    try:
        anim = Animation(default_framerate=fps)
        spacing = 0.0
        for k, res in enumerate(results):
            name = ROOT if len(results) == 1 else f"{ROOT}_{k + 1}_{_safe(res.scenario_name)}"
            spacing = max(spacing, _extent(res) + 2.0)
            build_scene(
                vis, robot, res, fps=fps, animation=anim, root=name, offset=(0.0, -k * spacing)
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


def build_scene(
    vis: meshcat.Visualizer,
    robot: FreeFloatingRobot,
    result: RunResult,
    *,
    fps: float = 30.0,
    animation: Animation | None = None,
    root: str = ROOT,
    offset: tuple[float, float] = (0.0, 0.0),
) -> Animation:
    """Put the robot, the reference and the paths of ``result`` into ``vis`` and animate them.

    When ``animation`` is None a new one is made and sent with ``vis.set_animation``;
    otherwise frames are added to it and the caller sends it. The scene is centred on the
    origin (the camera orbits about it), shifted by ``offset`` [m].
    """
    if fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    own_animation = animation is None
    anim = Animation(default_framerate=fps) if own_animation else animation
    t = np.asarray(result["t"], dtype=float)
    q = np.asarray(result["q"], dtype=float)
    if len(t) == 0:
        raise ValueError("the run has no recorded sample to replay")
    frames = frame_indices(t, fps)
    good = np.all(np.isfinite(q[frames]), axis=1)
    frames = frames[good] if good.any() else frames[:1]

    model = robot.model
    data = model.createData()
    gmodel = pin.buildGeomFromUrdfString(model, robot.urdf_xml, pin.GeometryType.VISUAL)
    gdata = pin.GeometryData(gmodel)

    center = _center(result)
    group = vis[root]
    shift = np.eye(4)
    shift[:2, 3] = -center + np.asarray(offset, dtype=float)
    group.set_transform(shift)

    shapes = []
    for obj in gmodel.geometryObjects:
        shape = _meshcat_shape(obj)
        if shape is None:
            warnings.warn(
                f"replay: visual geometry {obj.name!r} ({type(obj.geometry).__name__}) is not "
                "drawn (only boxes, spheres and cylinders are)",
                stacklevel=2,
            )
            continue
        geom, intrinsic = shape
        group["robot"][obj.name].set_object(geom, _material(obj.meshColor))
        shapes.append((len(shapes), obj.name, intrinsic, gmodel.getGeometryId(obj.name)))

    z_e, z_d = np.asarray(result["z_e"]), np.asarray(result["z_e_d"])
    _line(group["reference"]["path"], z_d[np.isfinite(z_d).all(axis=1)], _REFERENCE_COLOR, 0.005)
    _line(group["ee_path"], z_e[np.isfinite(z_e).all(axis=1)], _PATH_COLOR, 0.0)
    group["reference"]["target"].set_object(
        mg.Sphere(0.06), mg.MeshLambertMaterial(color=_REFERENCE_COLOR, opacity=0.8)
    )

    for k, i in enumerate(frames):
        pin.forwardKinematics(model, data, q[i])
        pin.updateGeometryPlacements(model, data, gmodel, gdata)
        poses = {name: gdata.oMg[gid].homogeneous @ intrinsic for _, name, intrinsic, gid in shapes}
        target = np.eye(4)
        target[:2, 3] = z_d[i, :2]
        target[2, 3] = 0.005
        with anim.at_frame(group, k) as frame:
            for name, pose in poses.items():
                frame["robot"][name].set_transform(pose)
            frame["reference"]["target"].set_transform(target)
        if k == 0:  # the still picture before the animation starts
            for name, pose in poses.items():
                group["robot"][name].set_transform(pose)
            group["reference"]["target"].set_transform(target)

    _set_camera(vis, _extent(result))
    if own_animation:
        vis.set_animation(anim, play=True, repetitions=1)
    return anim


def frame_indices(t: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the recorded samples closest to the frame times 0, 1/fps, 2/fps, ... [s]."""
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return np.zeros(0, dtype=int)
    times = np.arange(0.0, t[-1] + 0.5 / fps, 1.0 / fps) + t[0]
    idx = np.clip(np.searchsorted(t, times), 0, len(t) - 1)
    prev = np.clip(idx - 1, 0, len(t) - 1)
    closer = np.abs(t[prev] - times) < np.abs(t[idx] - times)
    return np.unique(np.where(closer, prev, idx))


# ------------------------------------------------------------------------------ helpers
def _meshcat_shape(obj) -> tuple[mg.Geometry, np.ndarray] | None:
    """meshcat geometry for a Pinocchio visual object, and the intrinsic transform to apply."""
    g = obj.geometry
    kind = type(g).__name__
    eye = np.eye(4)
    if kind == "Box":
        return mg.Box(list(2.0 * np.asarray(g.halfSide))), eye
    if kind == "Sphere":
        return mg.Sphere(float(g.radius)), eye
    if kind == "Cylinder":
        # meshcat (three.js) cylinders run along y, URDF cylinders along z
        rot = np.eye(4)
        rot[:3, :3] = pin.utils.rotate("x", np.pi / 2)
        return mg.Cylinder(2.0 * float(g.halfLength), float(g.radius)), rot
    return None


def _material(rgba) -> mg.MeshLambertMaterial:
    rgba = np.clip(np.asarray(rgba, dtype=float), 0.0, 1.0)
    if rgba.shape != (4,) or np.all(rgba == 0):
        rgba = np.array([0.6, 0.6, 0.65, 1.0])
    r, g, b = (int(round(255 * c)) for c in rgba[:3])
    return mg.MeshLambertMaterial(
        color=(r << 16) + (g << 8) + b, opacity=float(rgba[3]), transparent=bool(rgba[3] < 1)
    )


def _line(vis, points: np.ndarray, color: int, z: float) -> None:
    if len(points) < 2:
        return
    step = max(1, len(points) // 2000)
    pts = points[::step, :2]
    xyz = np.column_stack([pts, np.full(len(pts), z)]).T.astype(np.float32)
    vis.set_object(mg.Line(mg.PointsGeometry(xyz), mg.LineBasicMaterial(color=color)))


def _finite_xy(result: RunResult) -> np.ndarray:
    pts = [np.asarray(result["q"])[:, :2], np.asarray(result["z_e_d"])[:, :2]]
    pts.append(np.asarray(result["z_e"])[:, :2])
    xy = np.concatenate(pts)
    return xy[np.isfinite(xy).all(axis=1)]


def _center(result: RunResult) -> np.ndarray:
    xy = _finite_xy(result)
    if len(xy) == 0:
        return np.zeros(2)
    return 0.5 * (xy.min(axis=0) + xy.max(axis=0))


def _extent(result: RunResult) -> float:
    xy = _finite_xy(result)
    if len(xy) == 0:
        return 5.0
    return float(np.max(xy.max(axis=0) - xy.min(axis=0))) + 2.0  # + the base's size


def _set_camera(vis: meshcat.Visualizer, extent: float) -> None:
    """Look down on the plane from slightly below (-y), at a distance fitting ``extent``."""
    d = 0.55 * extent + 1.0
    # three.js coordinates of the camera: (x, z_world, -y_world)
    vis["/Cameras/default"].set_transform(np.eye(4))
    vis["/Cameras/default/rotated/<object>"].set_property("position", [0.0, d, 0.35 * d])


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def _command_js(blob: bytes) -> str:
    return (
        '\nfetch("data:application/octet-binary;base64,{}")\n'
        "    .then(res => res.arrayBuffer())\n"
        "    .then(buffer => viewer.handle_command_bytearray(new Uint8Array(buffer)));\n"
    ).format(base64.b64encode(blob).decode("ascii"))


_VIEWER_JS: str | None = None


def _viewer_js() -> str:
    global _VIEWER_JS
    if _VIEWER_JS is None:
        dist = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        _VIEWER_JS = dist.read_text(encoding="utf-8")
    return _VIEWER_JS


# The page meshcat's server returns for "get_scene" (meshcat 0.3), with a caption added.
_HTML = """<!DOCTYPE html>
<html>
    <head> <meta charset=utf-8> <title>ffsm-pin replay (MeshCat)</title> </head>
    <body>
        <div id="meshcat-pane">
        </div>
        <script>
            {mainminjs}
        </script>
        <script>
            var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
            {commands}
        </script>
         <style>
            body {{margin: 0; }}
            #meshcat-pane {{
                width: 100vw;
                height: 100vh;
                overflow: hidden;
            }}
        </style>
        <script id="embedded-json"></script>
    </body>
</html>
"""
