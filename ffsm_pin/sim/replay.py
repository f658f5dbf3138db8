"""Replay a recorded run in meshcat: a self-contained HTML file, or a live server.

:func:`write_replay_html` writes meshcat's *static HTML* (the viewer's JavaScript inlined, the
scene and a :class:`meshcat.animation.Animation` embedded as base64 msgpack), so the file opens
from disk in any browser with no server and no network. The scene is recorded in-process by a
stand-in for meshcat's ZMQ server (:class:`SceneRecorder`), which keeps the same scene tree
and writes the same HTML as ``Visualizer.static_html()``, without starting a subprocess.

:func:`serve_replay` starts meshcat's own server (a subprocess), sends the same scene and
animation, and returns the visualizer; :func:`close_visualizer` stops the server.

The scene: every visual geometry of the URDF (boxes, spheres, cylinders, and the STL/OBJ/DAE
meshes it names, embedded in the page; see :mod:`ffsm_pin.sim.meshes`) moved per frame to
Pinocchio's placement ``oMg`` for the recorded configuration ``q``, a box for a root body
without visuals (the satellite), the end-effector reference path (green line) with a moving
target (green sphere), and the end-effector's actual path (red line). Planar robots
(``JointModelPlanar`` root) are drawn in the plane z = 0, spatial ones (``JointModelFreeFlyer``
root, q = x, y, z, qx, qy, qz, qw, joints) in 3-D.
"""

from __future__ import annotations

import base64
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import numpy as np
import pinocchio as pin

from ..errors import ParameterError
from .meshes import (
    DaeMeshGeometry,
    ReplayWarning,
    compact_mesh,
    embedded_bytes,
    material,
    meshcat_object,
    visual_geometry,
)
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
_BASE_RGBA = (0.85, 0.7, 0.25, 1.0)  # gold, like the planar robots' base
BASE_BOX = "base_box"  # node of the box drawn for a root body without visuals
DEFAULT_BASE_SIZE = (0.5, 0.5, 0.5)  # its size when the robot does not give one [m]
MAX_MESH_MB = 20.0  # mesh data embedded as the files are up to this size [MB], then compacted
ROOT_JOINT = 1  # Pinocchio index of the floating root joint

__all__ = [
    "ReplayRobot",
    "ReplayWarning",
    "SceneRecorder",
    "build_scene",
    "close_visualizer",
    "frame_indices",
    "placements",
    "serve_replay",
    "write_replay_html",
]


class ReplayRobot(Protocol):
    """What the replay needs of a robot (planar ``FreeFloatingRobot``, spatial robots alike).

    Optional attributes: ``urdf_path`` (mesh paths relative to it), ``package_dirs`` or
    ``mesh_dirs`` (folders holding the packages of ``package://`` mesh paths), ``satellite``
    with ``size`` (3 edges [m] of the box drawn for a root body without visuals).
    """

    model: pin.Model
    urdf_xml: str


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
        """Record one meshcat command (as meshcat's visualizer would send it)."""
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
        """Nothing to close: the recording lives in memory."""


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

    fps: animation frames per second of simulated time (the run is decimated to it; playback
    is in real time). base_size: edges [m] of the box drawn at a root body without visuals
    when the robot gives no satellite size. max_mesh_mb: mesh data embedded as the files are
    up to this size [MB] (beyond it, DAE/OBJ meshes go in as binary STL). Returns the path
    written.
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


def build_scene(
    vis: meshcat.Visualizer,
    robot: ReplayRobot,
    result: RunResult,
    *,
    fps: float = 30.0,
    animation: Animation | None = None,
    root: str = ROOT,
    offset: tuple[float, float] = (0.0, 0.0),
    base_size: Sequence[float] = DEFAULT_BASE_SIZE,
    max_mesh_mb: float = MAX_MESH_MB,
) -> Animation:
    """Put the robot, the reference and the paths of ``result`` into ``vis`` and animate them.

    ``robot`` needs ``.model`` (its Pinocchio model, planar or free-flyer root) and
    ``.urdf_xml``; ``.urdf_path`` and ``.package_dirs`` (or ``.mesh_dirs``), when present, are
    where mesh files are looked for. A root body without visuals of its own is drawn as a box:
    ``.satellite.size`` [m], when present, centred on the root frame (the satellite link),
    else ``base_size`` [m] under it (its top face through the root frame's origin). ``result``
    needs the signals ``t``, ``q``, ``z_e`` and ``z_e_d`` (end-effector position first).
    When the mesh files together exceed ``max_mesh_mb`` [MB], DAE and OBJ meshes are embedded
    as binary STL in one colour each (:func:`ffsm_pin.sim.meshes.compact_mesh`).

    When ``animation`` is None a new one is made and sent with ``vis.set_animation``;
    otherwise frames are added to it and the caller sends it. The scene is centred on the
    origin (the camera orbits about it), shifted by ``offset`` [m] (x, y).
    """
    if fps <= 0:
        raise ParameterError(f"replay: fps must be > 0, got {fps}")
    own_animation = animation is None
    anim = Animation(default_framerate=fps) if own_animation else animation
    assert anim is not None
    t = np.asarray(result["t"], dtype=float)
    q = np.asarray(result["q"], dtype=float)
    if len(t) == 0:
        raise ParameterError("replay: the run has no recorded sample to replay")
    frames = frame_indices(t, fps)
    good = np.all(np.isfinite(q[frames]), axis=1)
    frames = frames[good] if good.any() else frames[:1]

    model = robot.model
    data = model.createData()
    dims = _dims(model)
    visuals = visual_geometry(
        model, robot.urdf_xml, getattr(robot, "urdf_path", None), _mesh_dirs(robot)
    )
    gmodel = visuals.geometry_model
    gdata = pin.GeometryData(gmodel)

    group = vis[root]
    drawn = []  # (node name, geometry id)
    for obj, shape in _shapes(gmodel, max_mesh_mb):
        node = group["robot"][obj.name]
        if isinstance(shape, DaeMeshGeometry):
            shape.path = node.path
            node.window.send(shape)
        else:
            node.set_object(shape)
        drawn.append((obj.name, gmodel.getGeometryId(obj.name)))

    base_box, box_in_root = None, np.eye(4)
    if not visuals.root_has_visual:
        size = getattr(getattr(robot, "satellite", None), "size", None)
        base_box = np.asarray(size if size is not None else base_size, dtype=float)
        if size is None:  # a bare arm root: the arm stands on the box (top face at z = 0)
            box_in_root[2, 3] = -0.5 * base_box[2]
        group["robot"][BASE_BOX].set_object(mg.Box(list(base_box)), material(_BASE_RGBA))

    # placements of every frame: geometries oMg and the base box [4x4, inertial frame]
    poses, roots = [], []
    for i in frames:
        poses.append(placements(model, data, gmodel, gdata, q[i]))
        roots.append(data.oMi[ROOT_JOINT].homogeneous @ box_in_root)

    z_e, z_d = np.asarray(result["z_e"], dtype=float), np.asarray(result["z_e_d"], dtype=float)
    ref_pts, ee_pts = _path_points(z_d, dims, 0.005), _path_points(z_e, dims, 0.0)
    _line(group["reference"]["path"], ref_pts, _REFERENCE_COLOR)
    _line(group["ee_path"], ee_pts, _PATH_COLOR)
    if dims == 2:  # the plane's motion, as seen from above
        center, extent = _center(result, dims), _path_extent(result, dims) + 2.0
    else:  # the paths and every geometry's origin in every frame
        origins = np.concatenate([np.reshape(poses, (-1, 4, 4)), roots])[:, :3, 3]
        pts = np.concatenate([ref_pts, ee_pts, origins])
        center = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        box = float(np.linalg.norm(base_box)) if base_box is not None else 0.0
        extent = float(np.max(np.ptp(pts, axis=0))) + box + 0.3
    shift = np.eye(4)
    shift[:dims, 3] = -center
    shift[:2, 3] += np.asarray(offset, dtype=float)
    group.set_transform(shift)
    group["reference"]["target"].set_object(
        mg.Sphere(min(0.06, 0.02 * extent)),
        mg.MeshLambertMaterial(color=_REFERENCE_COLOR, opacity=0.8),
    )
    target_pts = _path_points(z_d, dims, 0.005, decimate=False)

    for k, i in enumerate(frames):
        target = np.eye(4)
        target[:3, 3] = target_pts[i]
        # key at the sample's own time (the same as k for runs recorded finer than 1/fps)
        with anim.at_frame(group, int(round((t[i] - t[0]) * fps))) as frame:
            for name, gid in drawn:
                frame["robot"][name].set_transform(poses[k][gid])
            if base_box is not None:
                frame["robot"][BASE_BOX].set_transform(roots[k])
            frame["reference"]["target"].set_transform(target)
        if k == 0:  # the still picture before the animation starts
            for name, gid in drawn:
                group["robot"][name].set_transform(poses[k][gid])
            if base_box is not None:
                group["robot"][BASE_BOX].set_transform(roots[k])
            group["reference"]["target"].set_transform(target)

    _set_camera(vis, extent, dims)
    if own_animation:
        vis.set_animation(anim, play=True, repetitions=1)
    return anim


def _shapes(gmodel: pin.GeometryModel, max_mesh_mb: float) -> list:
    """(geometry object, meshcat object) of every visual that can be drawn; the others
    warned about. Meshes beyond the size budget compacted to binary STL (one warning)."""
    shapes = []
    for obj in gmodel.geometryObjects:
        try:
            shape = meshcat_object(obj)
        except Exception as exc:  # noqa: BLE001 - a file meshcat cannot read: leave it out
            shape, why = None, f"cannot be read ({type(exc).__name__}: {exc})"
        else:
            why = "is not drawn (only boxes, spheres, cylinders and STL/OBJ/DAE meshes are)"
        if shape is None:
            warnings.warn(
                f"replay: visual geometry {obj.name!r} ({type(obj.geometry).__name__}) {why}",
                ReplayWarning,
                stacklevel=3,
            )
        else:
            shapes.append((obj, shape))
    total = sum(embedded_bytes(shape) for _, shape in shapes)
    if total <= max_mesh_mb * 1e6:
        return shapes
    compacted = []
    for obj, shape in shapes:
        if Path(obj.meshPath).suffix.lower() in (".dae", ".obj"):
            shape = compact_mesh(obj)
        compacted.append((obj, shape))
    after = sum(embedded_bytes(shape) for _, shape in compacted)
    warnings.warn(
        f"replay: the robot's meshes take {total / 1e6:.1f} MB (more than {max_mesh_mb:g} MB): "
        f"DAE/OBJ meshes embedded as binary STL in one colour each, {after / 1e6:.1f} MB",
        ReplayWarning,
        stacklevel=3,
    )
    return compacted


def placements(
    model: pin.Model,
    data: pin.Data,
    gmodel: pin.GeometryModel,
    gdata: pin.GeometryData,
    q: np.ndarray,
) -> list[np.ndarray]:
    """4x4 placements oMg of every geometry (inertial frame) at configuration ``q``."""
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, gmodel, gdata)
    return [m.homogeneous for m in gdata.oMg]


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
def _dims(model: pin.Model) -> int:
    """2 for a planar root joint (the scene lies in z = 0), else 3."""
    return 2 if model.joints[ROOT_JOINT].shortname() == "JointModelPlanar" else 3


def _mesh_dirs(robot) -> list:
    dirs = getattr(robot, "package_dirs", None) or getattr(robot, "mesh_dirs", None) or ()
    return [dirs] if isinstance(dirs, (str, Path)) else list(dirs)


def _path_points(z: np.ndarray, dims: int, plane_z: float, decimate: bool = True) -> np.ndarray:
    """(n, 3) points of an end-effector signal: x, y, z (planar: at height ``plane_z`` [m]).

    With ``decimate``, non-finite rows are dropped and at most about 2000 points kept."""
    z = np.asarray(z, dtype=float)
    if dims == 2:
        pts = np.column_stack([z[:, :2], np.full(len(z), plane_z)])
    else:
        pts = z[:, :3]
    if decimate:
        pts = pts[np.isfinite(pts).all(axis=1)]
        pts = pts[:: max(1, len(pts) // 2000)]
    return pts


def _line(vis, points: np.ndarray, color: int) -> None:
    if len(points) < 2:
        return
    xyz = np.asarray(points, dtype=np.float32).T
    vis.set_object(mg.Line(mg.PointsGeometry(xyz), mg.LineBasicMaterial(color=color)))


def _finite_points(result: RunResult, dims: int) -> np.ndarray:
    """Base origin and end-effector positions (actual and reference), finite rows only."""
    pts = [np.asarray(result["q"])[:, :dims], np.asarray(result["z_e_d"])[:, :dims]]
    pts.append(np.asarray(result["z_e"])[:, :dims])
    xy = np.concatenate(pts)
    return xy[np.isfinite(xy).all(axis=1)]


def _center(result: RunResult, dims: int = 2) -> np.ndarray:
    pts = _finite_points(result, dims)
    if len(pts) == 0:
        return np.zeros(dims)
    return 0.5 * (pts.min(axis=0) + pts.max(axis=0))


def _path_extent(result: RunResult, dims: int = 2) -> float:
    pts = _finite_points(result, dims)
    return float(np.max(np.ptp(pts, axis=0))) if len(pts) else 3.0


def _set_camera(vis: meshcat.Visualizer, extent: float, dims: int = 2) -> None:
    """Planar: look down on the plane from slightly below (-y); spatial: an oblique view from
    (+x, -y, +z). At a distance fitting ``extent`` [m]."""
    # three.js coordinates of the camera: (x, z_world, -y_world)
    vis["/Cameras/default"].set_transform(np.eye(4))
    if dims == 2:
        d = 0.55 * extent + 1.0
        position = [0.0, d, 0.35 * d]
    else:
        d = 1.0 * extent + 0.3  # |(0.55, 0.45, 0.7)| = 1: extent fills ~2/3 of the view
        position = [0.55 * d, 0.45 * d, 0.7 * d]
    vis["/Cameras/default/rotated/<object>"].set_property("position", position)


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
