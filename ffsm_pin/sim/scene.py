"""The replay's meshcat scene of a recorded run (:func:`build_scene`).

The scene: every visual geometry of the URDF (boxes, spheres, cylinders, and the STL/OBJ/DAE
meshes it names, embedded in the page; see :mod:`ffsm_pin.sim.meshes`) moved per frame to
Pinocchio's placement ``oMg`` for the recorded configuration ``q``, a box for a root body
without visuals (the satellite), the end-effector reference path (green line) with a moving
target (green sphere), the end-effector's actual path (red line), and the ``[target]`` body
of a run that has one (a box at its recorded ``target_pose``), with the grasp frames and the
wheels' stored momentum (:mod:`.scene_marks`). Planar robots
(``JointModelPlanar`` root) are drawn in the plane z = 0, spatial ones (``JointModelFreeFlyer``
root, q = x, y, z, qx, qy, qz, qw, joints) in 3-D.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import numpy as np
import pinocchio as pin

from .._docstrings import fill_doc
from ..errors import ParameterError
from ._docs import SIM_DOC
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
from .scene_marks import capture_marks

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's deprecated zmq.eventloop.ioloop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import meshcat.geometry as mg
    from meshcat.animation import Animation

ROOT = "ffsm"  # all objects live under /meshcat/ffsm
_REFERENCE_COLOR = 0x22AA44
_PATH_COLOR = 0xCC2222
_BASE_RGBA = (0.85, 0.7, 0.25, 1.0)  # gold, like the planar robots' base
BASE_BOX = "base_box"  # node of the box drawn for a root body without visuals
TARGET_BOX = "target_box"  # node of the [target] body's box
CAPTURE_POINT = "capture_point"  # node of the hand's position at capture ([capture])
_CAPTURE_COLOR = 0xFF8800  # orange
_TARGET_RGBA = (0.55, 0.6, 0.7, 1.0)  # grey-blue
DEFAULT_BASE_SIZE = (0.5, 0.5, 0.5)  # its size when the robot does not give one [m]
MAX_MESH_MB = 20.0  # mesh data embedded as the files are up to this size [MB], then compacted
ROOT_JOINT = 1  # Pinocchio index of the floating root joint

__all__ = [
    "BASE_BOX",
    "CAPTURE_POINT",
    "TARGET_BOX",
    "ReplayRobot",
    "build_scene",
    "frame_indices",
    "placements",
    "target_placements",
]


class ReplayRobot(Protocol):
    """What the replay needs of a robot (planar ``FreeFloatingRobot``, spatial robots alike).

    Optional attributes: ``urdf_path`` (mesh paths relative to it), ``package_dirs`` or
    ``mesh_dirs`` (folders holding the packages of ``package://`` mesh paths), ``satellite``
    with ``size`` (3 edges [m] of the box drawn for a root body without visuals).
    """

    model: pin.Model
    urdf_xml: str


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
    needs the signals ``t``, ``q``, ``z_e`` and ``z_e_d`` (end-effector position first); a
    result with ``target_pose`` and its ``target`` (a box's ``size``) gets the target's box at
    its recorded poses and its grasp frame (a triad), one with a ``capture`` the hand's grasp
    frame (a triad) and, if it happened, an orange sphere at the hand's position at capture,
    shown from the capture on; one with wheels an arrow of their stored momentum
    (:mod:`.scene_marks`).
    When the mesh files together exceed ``max_mesh_mb`` [MB], DAE and OBJ meshes are embedded
    as binary STL in one colour each (:func:`ffsm_pin.sim.meshes.compact_mesh`).

    When ``animation`` is None a new one is made and sent with ``vis.set_animation``;
    otherwise frames are added to it and the caller sends it. The scene is centred on the
    origin (the camera orbits about it), shifted by ``offset`` [m] (x, y).

    Parameters
    ----------
    vis : meshcat.Visualizer
        The viewer.
    robot : ReplayRobot
        The robot drawn.
    result : RunResult
        The run replayed.
    fps : float
        Frames per second.
    animation : Animation or None
        The animation to add to; None: a new one, sent.
    root : str
        The scene path everything is put under.
    offset : tuple of float
        Shift (x, y) [m].
    base_size : sequence of float
        Box drawn for a root body without visuals [m].
    max_mesh_mb : float
        Mesh size budget [MB].

    Returns
    -------
    Animation
        The animation.
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

    target_size = getattr(getattr(result, "target", None), "size", None)
    targets = None  # the [target] box's placements [4x4, inertial frame], one per frame
    if target_size is not None and "target_pose" in result:
        targets = target_placements(np.asarray(result["target_pose"], dtype=float)[frames])
        group[TARGET_BOX].set_object(mg.Box(list(target_size)), material(_TARGET_RGBA))
    z_e, z_d = np.asarray(result["z_e"], dtype=float), np.asarray(result["z_e_d"], dtype=float)
    ref_pts, ee_pts = _path_points(z_d, dims, 0.005), _path_points(z_e, dims, 0.0)
    _line(group["reference"]["path"], ref_pts, _REFERENCE_COLOR)
    _line(group["ee_path"], ee_pts, _PATH_COLOR)
    if dims == 2:  # the plane's motion, as seen from above
        center, extent = _center(result, dims), _path_extent(result, dims) + 2.0
    else:  # the paths and every geometry's origin in every frame
        moving: list[np.ndarray] = [np.reshape(poses, (-1, 4, 4)), np.reshape(roots, (-1, 4, 4))]
        if targets is not None:  # (the target's path too)
            moving.append(targets)
        origins = np.concatenate(moving)[:, :3, 3]
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
    # the grasp frames and the wheels' stored momentum (sim/scene_marks.py)
    marks = capture_marks(robot, result, frames, targets)
    for mark in marks:
        mark.draw(group)

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
            if targets is not None:
                frame[TARGET_BOX].set_transform(targets[k])
            for mark in marks:
                mark.key(frame, k)
        if k == 0:  # the still picture before the animation starts
            for name, gid in drawn:
                group["robot"][name].set_transform(poses[k][gid])
            if base_box is not None:
                group["robot"][BASE_BOX].set_transform(roots[k])
            group["reference"]["target"].set_transform(target)
            if targets is not None:
                group[TARGET_BOX].set_transform(targets[k])

    _mark_capture(group, anim, result, z_e, t, fps)
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


@fill_doc(SIM_DOC)
def placements(
    model: pin.Model,
    data: pin.Data,
    gmodel: pin.GeometryModel,
    gdata: pin.GeometryData,
    q: np.ndarray,
) -> list[np.ndarray]:
    """4x4 placements oMg of every geometry (inertial frame) at configuration ``q``.

    Parameters
    ----------
    %(model_data)s
    gmodel : pin.GeometryModel
        The geometries.
    gdata : pin.GeometryData
        Their data.
    q : ndarray
        Configuration (Pinocchio convention).

    Returns
    -------
    list of ndarray
        One (4, 4) placement per geometry.
    """
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, gmodel, gdata)
    return [m.homogeneous for m in gdata.oMg]


def _mark_capture(group, anim: Animation, result, z_e: np.ndarray, t: np.ndarray, fps: float):
    """The capture instant: a sphere at the hand's recorded position at ``capture.time``,
    hidden at the first frame and shown from the capture's frame on (nothing without one)."""
    capture = getattr(result, "capture", None)
    if capture is None or not capture.captured or z_e.shape[1] < 3:
        return
    row = int(np.argmin(np.abs(t - capture.time)))
    node = group[CAPTURE_POINT]
    node.set_object(mg.Sphere(0.03), mg.MeshLambertMaterial(color=_CAPTURE_COLOR, opacity=0.8))
    place = np.eye(4)
    place[:3, 3] = z_e[row, :3]
    node.set_transform(place)
    node.set_property("visible", False)  # (the still picture before the animation: t[0])
    for time, shown in ((t[0], False), (capture.time, True)):
        with anim.at_frame(group, int(round((time - t[0]) * fps))) as frame:
            frame[CAPTURE_POINT].set_property("visible", "boolean", shown)


def target_placements(pose: np.ndarray) -> np.ndarray:
    """4x4 placements of the target frame from rows of ``target_pose`` (position [m],
    quaternion x, y, z, w), shape (rows, 4, 4)."""
    return np.array([pin.XYZQUATToSE3(row).homogeneous for row in pose]).reshape(-1, 4, 4)


def frame_indices(t: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the recorded samples closest to the frame times 0, 1/fps, 2/fps, ... [s].

    Parameters
    ----------
    t : ndarray
        Recorded times [s].
    fps : float
        Frames per second.

    Returns
    -------
    ndarray of int
        One index per frame.
    """
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
