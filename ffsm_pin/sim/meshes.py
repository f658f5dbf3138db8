"""The visual geometry of a robot for the replay, as meshcat objects.

:func:`visual_geometry` finds every mesh file the URDF's ``<visual>`` elements name
(``package://`` paths searched in the given package directories and, as yourdfpy does, upwards
from the URDF's folder; paths relative to the URDF; absolute paths and ``file://``), and builds
Pinocchio's VISUAL geometry model from the URDF with those files. A visual whose mesh is not
found is dropped with one :class:`ReplayWarning` naming the file and the link: it is drawn as
nothing.

:func:`meshcat_object` turns one Pinocchio geometry object into something ``set_object`` can
send: boxes, spheres and cylinders as meshcat primitives; STL and OBJ meshes as meshcat mesh
geometries in the URDF's colour; Collada (DAE) files as Pinocchio's own ``DaeMeshGeometry``
(the file's materials are kept) or, when the URDF gives a colour, as a mesh geometry in that
colour; each carrying the file's bytes so the page stays self-contained. The URDF mesh scale
and the meshcat/URDF axis change of cylinders live in the object's own matrix, so the node's
transform is exactly Pinocchio's placement ``oMg`` of the geometry.
"""

from __future__ import annotations

import io
import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pinocchio as pin
from yourdfpy.urdf import filename_handler_magic, filename_handler_meta

from ..errors import UrdfError
from ..robot.native import native_call

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's deprecated zmq.eventloop.ioloop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat.geometry as mg
    from pinocchio.visualize.meshcat_visualizer import DaeMeshGeometry

_MESH_FORMATS = (".stl", ".obj", ".dae")
_DEFAULT_RGBA = (0.6, 0.6, 0.65, 1.0)


class ReplayWarning(UserWarning):
    """Something of the robot that the replay cannot draw (it is left out, the replay goes on)."""


class RobotVisuals(NamedTuple):
    """Pinocchio's VISUAL geometry model of a robot and what could not be drawn."""

    geometry_model: pin.GeometryModel
    missing: tuple[str, ...]  # mesh file names (as written in the URDF) that were not found
    root_link: str  # the URDF's root link (the body of the floating root joint)
    root_has_visual: bool  # whether that link has a visual of its own


def visual_geometry(
    model: pin.Model,
    urdf_xml: str,
    urdf_path: str | Path | None = None,
    package_dirs: Sequence[str | Path] = (),
) -> RobotVisuals:
    """Pinocchio's VISUAL geometry model of ``urdf_xml`` (built on ``model``) with every mesh
    file resolved to an absolute path; visuals whose mesh is not found are dropped, one
    :class:`ReplayWarning` each.

    Parameters
    ----------
    model : pin.Model
        The robot's Pinocchio model.
    urdf_xml : str
        The URDF.
    urdf_path : str or Path or None
        The URDF's file, for paths relative to it and for the upward ``package://`` search.
    package_dirs : sequence of str or Path
        Folders holding the packages that ``package://NAME/...`` names.

    Returns
    -------
    RobotVisuals
        The visual geometry model and the meshes not found.
    """
    root = ET.fromstring(urdf_xml)
    base_dir = Path(urdf_path).resolve().parent if urdf_path is not None else None
    dirs = [Path(d) for d in package_dirs]
    missing = []
    for link in root.iter("link"):
        for visual in list(link.findall("visual")):
            mesh = visual.find("geometry/mesh")
            if mesh is None:
                continue
            name = mesh.get("filename", "")
            found = resolve_mesh(name, base_dir, dirs)
            if found is None:
                link.remove(visual)
                missing.append(name)
                where = ", ".join(str(d) for d in [*dirs, base_dir] if d is not None) or "nowhere"
                warnings.warn(
                    f"replay: mesh {name!r} of link {link.get('name')!r} not found "
                    f"(searched: {where}); it is not drawn",
                    ReplayWarning,
                    stacklevel=3,
                )
            else:
                mesh.set("filename", str(found))
    xml = ET.tostring(root, encoding="unicode")
    gmodel = _build_visuals(model, xml, urdf_path)
    root_link = _root_link(root)
    has_visual = any(
        link.get("name") == root_link and link.find("visual") is not None
        for link in root.iter("link")
    )
    return RobotVisuals(gmodel, tuple(missing), root_link, has_visual)


def _build_visuals(model: pin.Model, xml: str, urdf_path: str | Path | None) -> pin.GeometryModel:
    """``pin.buildGeomFromUrdfString`` (urdfdom parses the URDF, assimp reads the meshes) with
    what those C++ libraries print captured: a failure is a :class:`UrdfError` quoting it in one
    line, other output one :class:`ReplayWarning`."""
    source = Path(urdf_path).name if urdf_path is not None else "URDF"
    call = native_call(pin.buildGeomFromUrdfString, model, xml, pin.GeometryType.VISUAL)
    told = call.output.summary()
    if call.failure is not None:
        also = f" ({told})" if told and told not in call.failure else ""
        raise UrdfError(
            f"{source}: Pinocchio cannot read the visual geometry: {call.failure}{also}"
        )
    if told:
        warnings.warn(
            f"replay: {source}: the URDF and mesh readers say: {told}", ReplayWarning, stacklevel=3
        )
    return call.value


def resolve_mesh(filename: str, base_dir: Path | None, package_dirs: Sequence[Path]) -> Path | None:
    """Absolute path of the mesh file a URDF names, or None when no candidate exists.

    Parameters
    ----------
    filename : str
        The file name the URDF gives (``package://``, ``file://``, relative or absolute).
    base_dir : Path or None
        The URDF's folder.
    package_dirs : sequence of Path
        Folders holding the packages.

    Returns
    -------
    Path or None
        The file.
    """
    if not filename:
        return None
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        for d in package_dirs:
            if (d / rest).is_file():
                return (d / rest).resolve()
    handlers: list[Callable[[str], str]] = []
    if base_dir is not None:
        handlers.append(partial(filename_handler_magic, dir=str(base_dir)))
    elif filename.startswith("file://") or os.path.isabs(filename):
        handlers.append(lambda fname: fname.removeprefix("file://"))
    if not handlers:
        return None
    with _quiet_yourdfpy():
        found = filename_handler_meta(filename, handlers)
    return Path(found).resolve() if os.path.isfile(found) else None


def meshcat_object(obj: pin.GeometryObject) -> mg.Mesh | DaeMeshGeometry | None:
    """A meshcat scene object for one Pinocchio visual geometry object, or None if its kind is
    not drawn (anything but boxes, spheres, cylinders and STL/OBJ/DAE meshes)."""
    g = obj.geometry
    kind = type(g).__name__
    scale = np.diag([*np.asarray(obj.meshScale, dtype=float), 1.0])
    path = Path(obj.meshPath) if obj.meshPath else None
    if path is not None and path.suffix.lower() in _MESH_FORMATS and path.is_file():
        ext = path.suffix.lower()
        if ext == ".dae" and not obj.overrideMaterial:  # the whole file, its own materials
            try:
                dae = DaeMeshGeometry(str(path))  # textures embedded as data: URLs
            except UserWarning as exc:  # Pinocchio raises it for a texture it cannot find
                warnings.warn(
                    f"replay: {exc} ({path.name}, visual {obj.name!r}): drawn in one colour",
                    ReplayWarning,
                    stacklevel=2,
                )
            else:
                dae.intrinsic_transform = scale  # column-major = row-major for a diagonal
                return dae
        # STL, OBJ, and DAE with a URDF colour: the file's triangles in the URDF's material
        # (meshcat's viewer ignores a material sent with a whole-file Collada object)
        reader = {".stl": mg.StlMeshGeometry, ".obj": mg.ObjMeshGeometry}.get(
            ext, mg.DaeMeshGeometry
        )
        geom = reader.from_file(str(path))
        return mg.Mesh(_Placed(geom, scale), material(obj.meshColor))
    if kind == "Box":
        return mg.Mesh(mg.Box(list(2.0 * np.asarray(g.halfSide))), material(obj.meshColor))
    if kind == "Sphere":
        return mg.Mesh(mg.Sphere(float(g.radius)), material(obj.meshColor))
    if kind == "Cylinder":
        # three.js cylinders run along y, URDF cylinders along z: rotate y onto z
        rot = np.eye(4)
        rot[:3, :3] = pin.utils.rotate("x", np.pi / 2)
        cylinder = mg.Cylinder(2.0 * float(g.halfLength), float(g.radius))
        return mg.Mesh(_Placed(cylinder, rot), material(obj.meshColor))
    return None


def compact_mesh(obj: pin.GeometryObject) -> mg.Mesh:
    """The mesh of ``obj`` as binary STL (trimesh reads the file: Collada nodes, units and
    up-axis applied), in one colour: the URDF's if it gives one, else the file's materials
    averaged over their surface areas. Binary STL is 50 bytes a triangle, about 0.6 times
    the Collada text of example-robot-data's arms; the files' multiple colours are lost."""
    import trimesh  # noqa: PLC0415 - only for robots whose meshes exceed the size budget

    scene = trimesh.load(obj.meshPath, force="scene")
    parts = scene.dump()  # type: ignore[attr-defined]  # a Scene (force="scene"): its meshes in the file's root frame
    mesh = trimesh.util.concatenate(parts) if len(parts) > 1 else parts[0]
    if obj.overrideMaterial:
        rgba = np.asarray(obj.meshColor, dtype=float)
    else:
        colors, areas = [], []
        for part in parts:
            visual = part.visual
            color = getattr(visual, "main_color", None)
            if color is None:
                color = getattr(getattr(visual, "material", None), "main_color", None)
            if color is not None:
                colors.append(np.asarray(color, dtype=float)[:4] / 255.0)
                areas.append(part.area)
        rgba = np.average(colors, axis=0, weights=areas) if colors else np.array(_DEFAULT_RGBA)
    scale = np.diag([*np.asarray(obj.meshScale, dtype=float), 1.0])
    stl = mg.StlMeshGeometry.from_stream(io.BytesIO(mesh.export(file_type="stl")))  # type: ignore[call-arg]  # trimesh's stubs: file_obj is optional
    return mg.Mesh(_Placed(stl, scale), material(rgba))


def material(rgba) -> mg.MeshLambertMaterial:
    """meshcat material of an RGBA colour (0..1); all zeros (no colour given) -> grey."""
    rgba = np.clip(np.asarray(rgba, dtype=float), 0.0, 1.0)
    if rgba.shape != (4,) or np.all(rgba == 0):
        rgba = np.array(_DEFAULT_RGBA)
    r, g, b = (int(round(255 * c)) for c in rgba[:3])
    return mg.MeshLambertMaterial(
        color=(r << 16) + (g << 8) + b, opacity=float(rgba[3]), transparent=bool(rgba[3] < 1)
    )


def embedded_bytes(obj) -> int:
    """Size of the mesh file data a meshcat object carries [bytes] (0 for primitives)."""
    if isinstance(obj, DaeMeshGeometry):
        return len(obj.dae_raw.encode("utf-8"))
    geom = getattr(obj, "geometry", None)
    geom = getattr(geom, "inner", geom)
    data = getattr(geom, "contents", None)
    data = getattr(data, "data", data)  # STL bytes come wrapped in a msgpack Ext
    return len(data) if data is not None else 0


# ------------------------------------------------------------------------------ helpers
class _Placed(mg.Geometry):
    """A meshcat geometry with a fixed matrix of its own (URDF mesh scale, cylinder axis)."""

    def __init__(self, inner: mg.Geometry, matrix: np.ndarray) -> None:
        super().__init__()
        self.inner = inner
        self.uuid = inner.uuid
        self.matrix = np.asarray(matrix, dtype=float)

    def lower(self, object_data):
        return self.inner.lower(object_data)

    def intrinsic_transform(self) -> np.ndarray:
        # meshcat 0.3 sends this matrix flattened row by row; three.js reads it column by column
        return self.matrix.T


def _root_link(root: ET.Element) -> str:
    children = {c.get("link") for c in root.iter("child")}
    roots = [link.get("name") for link in root.iter("link") if link.get("name") not in children]
    return (roots[0] or "") if roots else ""


class _quiet_yourdfpy:
    """yourdfpy logs every unresolved candidate; the replay warns once per missing mesh."""

    def __enter__(self):
        import logging  # noqa: PLC0415

        self._logger = logging.getLogger("yourdfpy.urdf")
        self._level = self._logger.level
        self._logger.setLevel(logging.ERROR)

    def __exit__(self, *exc):
        self._logger.setLevel(self._level)
