"""Load a spatial free-floating manipulator (free-flyer root) from URDF into Pinocchio.

The root link of the URDF (or a satellite body added under it) becomes the floating base with
a ``JointModelFreeFlyer`` root joint: q = (x, y, z, qx, qy, qz, qw, q_m), v = (v_B, w_B, dq_m)
with the base's linear and angular velocity in the *base* frame; gravity is zero. Every
other movable joint must be revolute (or continuous) with any axis and any joint-origin
rotation; fixed joints are merged by Pinocchio. Grippers and other branches are held at a
value with ``locked_joints`` (``pin.buildReducedModel``).

``urdf = "example-robot-data:<name>"`` loads an arm shipped with the ``example-robot-data``
package (see :data:`EXAMPLE_ROBOTS`), from its installed files (never copied).
"""

from __future__ import annotations

import importlib.metadata
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from .._arrays import read_only
from ..errors import (
    FrameNotFoundError,
    InertiaError,
    ParameterError,
    RobotFileError,
    UnsupportedJointError,
    UrdfError,
    choices_text,
    did_you_mean,
)
from . import mrp

ERD_PREFIX = "example-robot-data:"

#: example-robot-data arms: name -> (URDF path under ``robots/``, suggested end effector,
#: joints to lock for a single chain).
EXAMPLE_ROBOTS: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "panda": (
        "panda_description/urdf/panda.urdf",
        "panda_hand",
        ("panda_finger_joint1", "panda_finger_joint2"),
    ),
    "kinova": ("kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", ()),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", "ee_link", ()),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "ee_link", ()),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", "ee_link", ()),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", "link7", ()),
    "z1": ("z1_description/urdf/z1.urdf", "link06", ("jointGripper",)),
}

_REVOLUTE = {
    "JointModelRX": np.array([1.0, 0.0, 0.0]),
    "JointModelRY": np.array([0.0, 1.0, 0.0]),
    "JointModelRZ": np.array([0.0, 0.0, 1.0]),
}
_INERTIA_REL_TOL = 1e-9


# ---------------------------------------------------------------------------- data classes
@dataclass(frozen=True)
class Satellite:
    """A satellite body added under an arm's root link (for arm-only URDFs).

    ``inertia`` = (ixx, iyy, izz, ixy, ixz, iyz) about the satellite's CoM, which is the
    origin of the new root link [kg m^2]; ``size`` is the visual box [m]; the arm's root link
    is mounted at ``mount_xyz`` [m] with ``mount_rpy`` [rad] in the satellite frame.
    """

    mass: float = 500.0  # [kg]
    inertia: tuple[float, ...] = (80.0, 80.0, 80.0, 0.0, 0.0, 0.0)
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)
    mount_xyz: tuple[float, float, float] = (0.0, 0.0, 0.5)
    mount_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = "satellite"

    def __post_init__(self) -> None:
        for key, n in (("inertia", 6), ("size", 3), ("mount_xyz", 3), ("mount_rpy", 3)):
            value = tuple(float(x) for x in getattr(self, key))
            if len(value) != n:
                raise ParameterError(f"satellite.{key}: expected {n} numbers, got {value}")
            object.__setattr__(self, key, value)
        object.__setattr__(self, "mass", float(self.mass))

    @classmethod
    def from_mapping(cls, table: Mapping) -> Satellite:
        """Build from a dict (e.g. a scenario's ``[robot.satellite]`` table); unknown keys are
        errors."""
        valid = ("mass", "inertia", "size", "mount_xyz", "mount_rpy", "name")
        for key in table:
            if key not in valid:
                raise ParameterError(
                    f"satellite: unknown key {key!r}{did_you_mean(key, valid)}; "
                    f"valid keys: {choices_text(valid)}"
                )
        return cls(**dict(table))

    def inertia_matrix(self) -> np.ndarray:
        xx, yy, zz, xy, xz, yz = self.inertia
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


@dataclass(frozen=True)
class SpatialGeometry:
    """Spatial serial chain extracted from a Pinocchio model (bodies 0..n, 0 = base).

    Body k's frame is the frame of joint k (the base frame for k = 0); vectors are in the
    frame of the body they belong to [m].
    """

    masses: np.ndarray  # (n+1,) [kg]
    inertias: np.ndarray  # (n+1, 3, 3) I_k about the body CoM, body frame [kg m^2]
    coms: np.ndarray  # (n+1, 3) c_k, CoM in body frame k
    joint_rotations: np.ndarray  # (n, 3, 3) rotation of joint k's placement in body k-1
    child_joints: np.ndarray  # (n, 3) a_k, origin of joint k+1 in body frame k
    axes: np.ndarray  # (n, 3) unit axis of joint k in its own frame
    ee_body: int  # body carrying the end-effector frame (1..n)
    ee_position: np.ndarray  # (3,) e, end-effector origin in body frame ee_body
    ee_rotation: np.ndarray  # (3, 3) end-effector frame orientation in body frame ee_body

    @property
    def n_joints(self) -> int:
        return len(self.axes)

    @property
    def total_mass(self) -> float:
        return float(self.masses.sum())


@dataclass(frozen=True)
class SpatialRobot:
    """A validated spatial free-floating robot: Pinocchio model plus its spatial geometry."""

    model: pin.Model
    urdf_path: Path
    urdf_xml: str  # the (possibly edited) URDF text given to Pinocchio
    ee_frame: str
    ee_frame_id: int
    geometry: SpatialGeometry
    body_names: tuple[str, ...]  # URDF link name of each body 0..n
    joint_names: tuple[str, ...]  # manipulator joints 1..n
    locked_joints: Mapping[str, float] = field(default_factory=dict)
    package_dirs: tuple[Path, ...] = ()  # where package:// mesh paths resolve

    base = "free-flyer"

    @property
    def n_joints(self) -> int:
        """m_1, the number of manipulator joints."""
        return self.geometry.n_joints

    @property
    def name(self) -> str:
        return self.model.name

    def neutral(self) -> np.ndarray:
        """Neutral configuration q (base at the origin, identity attitude, joints at zero)."""
        return pin.neutral(self.model)

    def configuration(self, base_pose, joints) -> np.ndarray:
        """Pinocchio q from a base pose (x, y, z, s1, s2, s3) [m, MRP] and joint angles [rad]."""
        base_pose = np.asarray(base_pose, dtype=float)
        joints = np.asarray(joints, dtype=float)
        if base_pose.shape != (6,):
            raise ParameterError(
                f"base pose must be (x, y, z, s1, s2, s3) [m, MRP], got shape {base_pose.shape}"
            )
        if joints.shape != (self.n_joints,):
            raise ParameterError(
                f"expected {self.n_joints} joint angles for {self.name!r}, got {joints.shape}"
            )
        return np.concatenate((base_pose[:3], mrp.to_quaternion(base_pose[3:]), joints))


# ---------------------------------------------------------------------------- URDF sources
def example_robot_data_dir() -> Path:
    """The installed ``example-robot-data`` share folder (holding ``robots/``)."""
    sub = Path("panda_description/urdf/panda.urdf")
    try:  # the Python module of older releases knows its model folder
        from example_robot_data.robots_loader import (  # type: ignore[import-not-found]
            EXAMPLE_ROBOT_DATA_MODEL_DIR,
        )

        robots = Path(EXAMPLE_ROBOT_DATA_MODEL_DIR)
        if (robots / sub).is_file():
            return robots.parent
    except (ImportError, AttributeError, TypeError):
        pass
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise RobotFileError(
            "the example-robot-data package is not installed (pip install example-robot-data)"
        ) from None
    for f in dist.files or ():
        parts = Path(str(f)).parts
        if "example-robot-data" in parts and "robots" in parts:
            i = parts.index("robots")
            if i > 0 and parts[i - 1] == "example-robot-data":
                return Path(str(dist.locate_file(Path(*parts[:i]))))
    raise RobotFileError("example-robot-data is installed but ships no robots/ folder")


def resolve_spatial_urdf(
    urdf: str | Path, relative_to: str | Path | None = None
) -> tuple[Path, tuple[Path, ...]]:
    """(URDF path, package dirs) for a path, a shipped name or ``example-robot-data:<name>``."""
    if isinstance(urdf, str) and urdf.startswith(ERD_PREFIX):
        name = urdf[len(ERD_PREFIX) :]
        if name not in EXAMPLE_ROBOTS:
            raise RobotFileError(
                f"unknown example-robot-data robot {name!r}"
                f"{did_you_mean(name, EXAMPLE_ROBOTS)}; valid names: "
                f"{choices_text(EXAMPLE_ROBOTS)}"
            )
        share = example_robot_data_dir()
        path = share / "robots" / EXAMPLE_ROBOTS[name][0]
        if not path.is_file():
            raise RobotFileError(f"example-robot-data robot {name!r}: {path} is missing")
        return path, (share.parent,)
    from ..robot import resolve_urdf

    path = resolve_urdf(urdf, relative_to)
    return path, (path.parent,)


# ---------------------------------------------------------------------------- XML edits
def _root_links(root: ET.Element) -> list[str]:
    links = [link.get("name") for link in root.findall("link")]
    children = {
        j.find("child").get("link") for j in root.findall("joint") if j.find("child") is not None
    }
    return [name for name in links if name not in children]


def _add_satellite(root: ET.Element, sat: Satellite, arm_root: str, source: str) -> None:
    names = {link.get("name") for link in root.findall("link")}
    if sat.name in names:
        raise UrdfError(f"{source}: satellite link name {sat.name!r} is already a link of the URDF")
    link = ET.Element("link", name=sat.name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=repr(sat.mass))
    ET.SubElement(
        inertial,
        "inertia",
        **{
            k: repr(v)
            for k, v in zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), sat.inertia, strict=True)
        },
    )
    visual = ET.SubElement(link, "visual")
    geometry = ET.SubElement(visual, "geometry")
    ET.SubElement(geometry, "box", size=" ".join(repr(s) for s in sat.size))
    joint = ET.Element("joint", name=f"{sat.name}_mount", type="fixed")
    ET.SubElement(joint, "parent", link=sat.name)
    ET.SubElement(joint, "child", link=arm_root)
    ET.SubElement(
        joint,
        "origin",
        xyz=" ".join(repr(v) for v in sat.mount_xyz),
        rpy=" ".join(repr(v) for v in sat.mount_rpy),
    )
    root.insert(0, joint)
    root.insert(0, link)


# ---------------------------------------------------------------------------- checks
def check_inertia(mass: float, inertia: np.ndarray, what: str) -> None:
    """Raise :class:`InertiaError` unless mass > 0 and the 3x3 inertia about the CoM is
    symmetric positive definite and satisfies the triangle inequality of its principal
    moments (I_a + I_b >= I_c, to a relative 1e-9)."""
    if not mass > 0:
        raise InertiaError(f"{what} has mass {mass}; every body needs a positive mass")
    inertia = np.asarray(inertia, dtype=float)
    scale = max(float(np.trace(inertia)), 1e-300)
    if np.abs(inertia - inertia.T).max() > _INERTIA_REL_TOL * scale:
        raise InertiaError(f"{what} has a non-symmetric inertia tensor")
    lam = np.linalg.eigvalsh(inertia)
    if not lam[0] > 0:
        raise InertiaError(
            f"{what} has principal moments {lam.tolist()} [kg m^2]; the inertia tensor must be "
            "positive definite"
        )
    if lam[0] + lam[1] < lam[2] * (1 - _INERTIA_REL_TOL):
        raise InertiaError(
            f"{what} has principal moments {lam.tolist()} [kg m^2] violating the triangle "
            "inequality I_a + I_b >= I_c; no rigid body has this inertia"
        )


def _joint_axis(jm, name: str, source: str) -> np.ndarray:
    short = jm.shortname()
    if short in _REVOLUTE:
        return _REVOLUTE[short].copy()
    if short == "JointModelRevoluteUnaligned":
        axis = np.array(jm.extract().axis, dtype=float)
        return axis / np.linalg.norm(axis)
    kind = {
        "JointModelPX": "prismatic",
        "JointModelPY": "prismatic",
        "JointModelPZ": "prismatic",
        "JointModelPrismaticUnaligned": "prismatic",
        "JointModelSpherical": "spherical",
        "JointModelSphericalZYX": "spherical",
        "JointModelPlanar": "planar",
        "JointModelFreeFlyer": "floating",
    }.get(short, short)
    raise UnsupportedJointError(
        f"{source}: joint {name!r} is {kind}; a spatial free-floating manipulator supports only "
        "revolute/continuous and fixed joints (lock it with locked_joints to hold it still)"
    )


def _body_name(model: pin.Model, j: int) -> str:
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint == j:
            return f.name
    return model.names[j]


# ---------------------------------------------------------------------------- loader
def load_spatial_robot(
    urdf: str | Path,
    end_effector: str,
    *,
    relative_to: str | Path | None = None,
    locked_joints: Mapping[str, float] | None = None,
    satellite: Satellite | Mapping | None = None,
) -> SpatialRobot:
    """Load and validate a spatial free-floating manipulator.

    Parameters
    ----------
    urdf:
        Path to a URDF, the name of a shipped robot, or ``"example-robot-data:<name>"``
        (names: :data:`EXAMPLE_ROBOTS`).
    end_effector:
        Name of the end-effector frame (a link or a fixed joint of the URDF).
    relative_to:
        Directory that relative paths are resolved against (e.g. a scenario file's folder).
    locked_joints:
        ``{joint name: value}`` [rad or m] of joints held fixed (grippers, unused branches).
    satellite:
        A :class:`Satellite` (or its dict) added as the new root body under the URDF's root
        link, for arm-only URDFs.

    Raises
    ------
    RobotFileError, UrdfError, UnsupportedJointError, InertiaError, FrameNotFoundError,
    ParameterError
    """
    from ..robot import _parse, _repair

    path, package_dirs = resolve_spatial_urdf(urdf, relative_to)
    source = path.name
    try:
        text = path.read_text()
    except OSError as exc:
        raise RobotFileError(f"cannot read URDF {str(path)!r}: {exc.strerror}") from None
    root = _parse(text, source)
    _repair(root, source)
    roots = _root_links(root)
    if len(roots) != 1:
        raise UrdfError(
            f"{source}: the URDF must have a single root link (the satellite body), found "
            f"{len(roots)}: {choices_text(roots)}"
        )
    if satellite is not None:
        if isinstance(satellite, Mapping):
            satellite = Satellite.from_mapping(satellite)
        _add_satellite(root, satellite, roots[0], source)
    xml = ET.tostring(root, encoding="unicode")
    try:
        model = pin.buildModelFromXML(xml, pin.JointModelFreeFlyer())
    except (RuntimeError, ValueError) as exc:
        raise UrdfError(f"{source}: Pinocchio cannot parse this URDF: {exc}") from None
    model.gravity.setZero()

    locked = {str(k): float(v) for k, v in (locked_joints or {}).items()}
    if locked:
        movable = [model.names[j] for j in range(2, model.njoints)]
        q_ref = pin.neutral(model)
        ids = []
        for name, value in locked.items():
            if not model.existJointName(name):
                raise UrdfError(
                    f"{source}: locked joint {name!r} not found{did_you_mean(name, movable)}; "
                    f"joints: {choices_text(movable)}"
                )
            jid = model.getJointId(name)
            if jid == 1:
                raise UrdfError(f"{source}: the floating root joint cannot be locked")
            if model.joints[jid].nq != 1:
                raise UnsupportedJointError(
                    f"{source}: locked joint {name!r} has {model.joints[jid].nq} coordinates; "
                    "only 1-coordinate joints can be locked at a value"
                )
            q_ref[model.joints[jid].idx_q] = value
            ids.append(jid)
        model = pin.buildReducedModel(model, sorted(ids), q_ref)
        model.gravity.setZero()

    n = model.njoints - 2
    if n < 1:
        raise UrdfError(f"{source}: the robot has no movable joint besides its floating base")

    # end-effector frame
    erd = urdf[len(ERD_PREFIX) :] if isinstance(urdf, str) and urdf.startswith(ERD_PREFIX) else None
    hint = ""
    if erd is not None:
        _, ee_hint, lock_hint = EXAMPLE_ROBOTS[erd]
        hint = f" (example-robot-data {erd!r}: end effector {ee_hint!r}"
        hint += f", usually locked: {choices_text(lock_hint)})" if lock_hint else ")"
    if not model.existFrame(end_effector):
        frames = [f.name for f in model.frames if f.name not in ("universe", "root_joint")]
        raise FrameNotFoundError(
            f"end-effector frame {end_effector!r} not found in {source}"
            f"{did_you_mean(end_effector, frames)}{hint}; frames: {choices_text(frames)}"
        )
    fid = model.getFrameId(end_effector)
    frame = model.frames[fid]
    ee_joint = int(frame.parentJoint)
    if ee_joint < 2:
        raise FrameNotFoundError(
            f"end-effector frame {end_effector!r} is attached to the base; it must be on a link"
        )

    # serial chain: every joint on the way to the end effector, nothing branching off
    on_path = set(model.supports[ee_joint])
    branching = [j for j in range(2, model.njoints) if model.parents[j] != j - 1]
    if branching:
        off_path = [model.names[j] for j in range(2, model.njoints) if j not in on_path]
        raise UnsupportedJointError(
            f"{source}: joint(s) {choices_text(model.names[j] for j in branching)} branch off "
            f"the chain to the end effector {end_effector!r}; lock the joints that are not on "
            f"it with locked_joints: {choices_text(off_path)}{hint}"
        )

    body_names = tuple(_body_name(model, j) for j in range(1, model.njoints))
    joint_names = tuple(model.names[j] for j in range(2, model.njoints))
    axes = [_joint_axis(model.joints[j], model.names[j], source) for j in range(2, model.njoints)]
    masses, inertias, coms = [], [], []
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        what = f"{source}: body {body_names[j - 1]!r}"
        try:
            check_inertia(float(inertia.mass), inertia.inertia, what)
        except InertiaError as exc:
            if j == 1 and satellite is None:  # the floating base itself
                raise InertiaError(
                    f"{exc}; it is the floating base (for an arm-only URDF, add a satellite "
                    "body with satellite=...)"
                ) from None
            raise
        masses.append(float(inertia.mass))
        inertias.append(np.array(inertia.inertia))
        coms.append(np.array(inertia.lever))
    rotations = [np.array(model.jointPlacements[j].rotation) for j in range(2, model.njoints)]
    child = [np.array(model.jointPlacements[j].translation) for j in range(2, model.njoints)]

    geometry = SpatialGeometry(
        masses=read_only(np.array(masses)),
        inertias=read_only(np.array(inertias)),
        coms=read_only(np.array(coms)),
        joint_rotations=read_only(np.array(rotations)),
        child_joints=read_only(np.array(child)),
        axes=read_only(np.array(axes)),
        ee_body=ee_joint - 1,
        ee_position=read_only(np.array(frame.placement.translation)),
        ee_rotation=read_only(np.array(frame.placement.rotation)),
    )
    return SpatialRobot(
        model=model,
        urdf_path=path,
        urdf_xml=xml,
        ee_frame=end_effector,
        ee_frame_id=fid,
        geometry=geometry,
        body_names=body_names,
        joint_names=joint_names,
        locked_joints=locked,
        package_dirs=package_dirs,
    )
