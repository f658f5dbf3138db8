"""Load a planar free-floating manipulator from URDF into Pinocchio, and validate it.

The root link of the URDF becomes a floating base with a ``JointModelPlanar`` root joint
(q = (x, y, cos q_b, sin q_b, q_m), v = (v_x, v_y, w_b, w_m) with the base twist in the
*base* frame), gravity is zero, and every other movable joint must be revolute about +-z.
:func:`load_robot` returns a :class:`FreeFloatingRobot`, which also carries the planar
geometry (:class:`PlanarGeometry`) that the barycentric model is built from.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ._arrays import read_only
from .errors import (
    FrameNotFoundError,
    InertiaError,
    RobotFileError,
    UnsupportedJointError,
    UrdfError,
    choices_text,
    did_you_mean,
)

if TYPE_CHECKING:
    from .spatial.robot import SpatialRobot

SUPPORTED_BASES = ("planar", "free-flyer")
_ANGLE_TOL = 1e-9


class UrdfWarning(UserWarning):
    """A URDF was accepted after a documented repair (e.g. a missing joint limit)."""


def urdf_dir() -> Path:
    """Folder of the shipped robot descriptions (package ``ffsm_pin.urdf``).

    Falls back to the top-level ``urdf/`` of a source checkout, for the case where the
    source tree shadows an installed copy on ``sys.path``.
    """
    try:
        return Path(str(resources.files("ffsm_pin.urdf")))
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[1] / "urdf"


def shipped_urdfs() -> list[str]:
    """Names of the robot descriptions shipped inside the package."""
    return sorted(p.name for p in urdf_dir().glob("*.urdf"))


def resolve_urdf(urdf: str | Path, relative_to: str | Path | None = None) -> Path:
    """Find a URDF: a path (absolute, or relative to ``relative_to`` or the working
    directory), or the name of a robot shipped with the package (``"ffsm_planar4.urdf"``)."""
    candidates = []
    p = Path(urdf)
    if relative_to is not None and not p.is_absolute():
        candidates.append(Path(relative_to) / p)
    candidates.append(p)
    for c in candidates:
        if c.is_file():
            return c
    shipped = urdf_dir() / p.name
    if p.parent == Path(".") and shipped.is_file():
        return Path(str(shipped))
    raise RobotFileError(
        f"URDF {str(urdf)!r} not found (looked in {', '.join(str(c) for c in candidates)}); "
        f"shipped robots: {choices_text(shipped_urdfs())}"
    )


@dataclass(frozen=True)
class PlanarGeometry:
    """Planar serial chain extracted from a Pinocchio model (bodies 0..n, 0 = base).

    All vectors are 2-D, in the frame of the body they belong to [m].
    """

    masses: np.ndarray  # (n+1,) [kg]
    inertias: np.ndarray  # (n+1,) I_zz about each body CoM [kg m^2]
    coms: np.ndarray  # (n+1, 2) c_k, CoM in body frame k
    child_joints: np.ndarray  # (n, 2) a_k, origin of joint k+1 in body frame k
    joint_yaws: np.ndarray  # (n,) fixed yaw of joint k's placement in its parent [rad]
    axis_signs: np.ndarray  # (n,) s_j = +1 (axis +z) or -1 (axis -z)
    ee_body: int  # body carrying the end-effector frame (1..n)
    ee_position: np.ndarray  # (2,) e, end-effector origin in body frame ee_body
    ee_yaw: float  # yaw of the end-effector frame in body frame ee_body [rad]

    @property
    def n_joints(self) -> int:
        return len(self.axis_signs)

    @property
    def total_mass(self) -> float:
        return float(self.masses.sum())


@dataclass(frozen=True)
class FreeFloatingRobot:
    """A validated planar free-floating robot: Pinocchio model plus its planar geometry."""

    model: pin.Model
    urdf_path: Path
    urdf_xml: str  # the (possibly repaired) URDF text given to Pinocchio
    ee_frame: str
    ee_frame_id: int
    geometry: PlanarGeometry
    body_names: tuple[str, ...]  # URDF link name of each body 0..n

    @property
    def n_joints(self) -> int:
        """m_1, the number of manipulator joints."""
        return self.geometry.n_joints

    @property
    def name(self) -> str:
        return self.model.name

    def neutral(self) -> np.ndarray:
        """Neutral configuration q (base at the origin, joints at zero)."""
        return pin.neutral(self.model)

    def configuration(self, base_pose, joints) -> np.ndarray:
        """Pinocchio q from a planar base pose (x, y, q_b) [m, m, rad] and joint angles [rad]."""
        x, y, qb = (float(v) for v in base_pose)
        joints = np.asarray(joints, dtype=float)
        if joints.shape != (self.n_joints,):
            raise UrdfError(
                f"expected {self.n_joints} joint angles for {self.name!r}, got {joints.shape}"
            )
        return np.concatenate(([x, y, math.cos(qb), math.sin(qb)], joints))


def add_missing_limits(text: str, source: str = "URDF") -> str:
    """Return URDF text where every revolute joint without ``<limit>`` gets one, and every
    'continuous' joint becomes 'revolute', each with a :class:`UrdfWarning` naming the joint.

    urdfdom (Pinocchio's parser) rejects revolute joints without limits outright; SPARTpy's
    bundled URDFs are an example. Limits are not enforced by the simulator.
    """
    root = _parse(text, source)
    if _repair(root, source):
        return ET.tostring(root, encoding="unicode")
    return text


def _parse(text: str, source: str) -> ET.Element:
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise UrdfError(f"{source}: not well-formed XML ({exc})") from None
    if root.tag != "robot":
        raise UrdfError(f"{source}: root element is <{root.tag}>, expected <robot>")
    return root


def _repair(root: ET.Element, source: str) -> bool:
    changed = False
    for joint in root.iter("joint"):
        name = joint.get("name", "?")
        if joint.get("type") == "continuous":
            warnings.warn(
                f"{source}: joint {name!r} is 'continuous'; treated as 'revolute' with "
                "limits +-2 pi (limits are not enforced by the simulator)",
                UrdfWarning,
                stacklevel=4,
            )
            joint.set("type", "revolute")
            changed = True
        if joint.get("type") == "revolute" and joint.find("limit") is None:
            warnings.warn(
                f"{source}: revolute joint {name!r} has no <limit>; added "
                "lower=-2pi upper=2pi effort=1e3 velocity=1e2 (not enforced by the simulator)",
                UrdfWarning,
                stacklevel=4,
            )
            ET.SubElement(
                joint,
                "limit",
                lower=repr(-2 * math.pi),
                upper=repr(2 * math.pi),
                effort="1000",
                velocity="100",
            )
            changed = True
    return changed


def _repair_and_check_xml(text: str, path: Path) -> str:
    """Check joint types/axes/origins for a planar chain, and repair missing limits."""
    root = _parse(text, path.name)
    changed = _repair(root, path.name)
    for joint in root.iter("joint"):
        name = joint.get("name", "?")
        jtype = joint.get("type")
        if jtype == "fixed":
            continue
        if jtype != "revolute":
            raise UnsupportedJointError(
                f"{path.name}: joint {name!r} has type {jtype!r}; a planar free-floating "
                "manipulator supports only 'revolute' (or 'continuous') joints about z and "
                "'fixed' joints"
            )
        axis_el = joint.find("axis")
        axis_text = "1 0 0" if axis_el is None else axis_el.get("xyz", "1 0 0")
        axis = np.asarray([float(v) for v in axis_text.split()], dtype=float)
        if np.linalg.norm(axis) == 0 or np.linalg.norm(axis[:2]) > 1e-9 * np.linalg.norm(axis):
            raise UnsupportedJointError(
                f"{path.name}: joint {name!r} has axis {tuple(axis.tolist())}; planar chains "
                "need every revolute axis along +z or -z ('0 0 1' or '0 0 -1')"
            )
        origin = joint.find("origin")
        if origin is not None:
            rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
            if abs(rpy[0]) > _ANGLE_TOL or abs(rpy[1]) > _ANGLE_TOL:
                raise UnsupportedJointError(
                    f"{path.name}: joint {name!r} origin has roll/pitch {rpy[:2]}; a planar "
                    "chain allows only a yaw (rotation about z) in joint origins"
                )
    return ET.tostring(root, encoding="unicode") if changed else text


def _yaw(rotation: np.ndarray) -> float:
    return math.atan2(rotation[1, 0], rotation[0, 0])


def load_robot(
    urdf: str | Path,
    end_effector: str = "ee",
    *,
    base: str = "planar",
    relative_to: str | Path | None = None,
    locked_joints: dict | None = None,
    satellite=None,
) -> FreeFloatingRobot | SpatialRobot:
    """Load and validate a planar free-floating manipulator (``base="planar"``), or a spatial
    one (``base="free-flyer"``: returns :func:`ffsm_pin.spatial.load_spatial_robot`'s
    ``SpatialRobot``; ``locked_joints`` and ``satellite`` are its options).

    Parameters
    ----------
    urdf:
        Path to a URDF, or the name of a shipped robot (see :func:`shipped_urdfs`).
    end_effector:
        Name of the end-effector frame (a link or a fixed joint of the URDF).
    base:
        Root joint type: ``"planar"`` or ``"free-flyer"``.
    relative_to:
        Directory that relative paths are resolved against (e.g. a scenario file's folder).

    Raises
    ------
    RobotFileError, UrdfError, UnsupportedJointError, InertiaError, FrameNotFoundError
    """
    if base not in SUPPORTED_BASES:
        raise UnsupportedJointError(
            f"base {base!r} is not supported; valid choices: {choices_text(SUPPORTED_BASES)}"
        )
    if base == "free-flyer":
        from .spatial.robot import load_spatial_robot

        return load_spatial_robot(
            urdf,
            end_effector,
            relative_to=relative_to,
            locked_joints=locked_joints,
            satellite=satellite,
        )
    if locked_joints or satellite is not None:
        raise UrdfError("options 'locked_joints' and 'satellite' apply only to base 'free-flyer'")
    path = resolve_urdf(urdf, relative_to)
    try:
        text = path.read_text()
    except OSError as exc:
        raise RobotFileError(f"cannot read URDF {str(path)!r}: {exc.strerror}") from None
    xml = _repair_and_check_xml(text, path)
    try:
        model = pin.buildModelFromXML(xml, pin.JointModelPlanar())
    except (RuntimeError, ValueError) as exc:
        raise UrdfError(f"{path.name}: Pinocchio cannot parse this URDF: {exc}") from None
    model.gravity.setZero()

    n = model.njoints - 2
    if n < 1:
        raise UrdfError(f"{path.name}: the robot has no movable joint besides its floating base")
    for j in range(2, model.njoints):
        if model.parents[j] != j - 1:
            raise UnsupportedJointError(
                f"{path.name}: joint {model.names[j]!r} branches off joint "
                f"{model.names[model.parents[j]]!r}; only serial chains are supported"
            )

    body_names = []
    for j in range(1, model.njoints):
        names = [
            f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == j
        ]
        body_names.append(names[0] if names else model.names[j])

    masses, inertias, coms = [], [], []
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        mass = float(inertia.mass)
        izz = float(inertia.inertia[2, 2])
        if not mass > 0:
            raise InertiaError(
                f"{path.name}: link {body_names[j - 1]!r} has mass {mass}; every body of a "
                "free-floating robot needs a positive mass (<inertial><mass>)"
            )
        if not izz > 0:
            raise InertiaError(
                f"{path.name}: link {body_names[j - 1]!r} has I_zz = {izz}; every body needs "
                "a positive rotational inertia about z"
            )
        masses.append(mass)
        inertias.append(izz)
        coms.append(np.array(inertia.lever[:2]))

    axis_signs, yaws, child = [], [], []
    for j in range(2, model.njoints):
        jm = model.joints[j]
        short = jm.shortname()
        if short == "JointModelRZ":
            sign = 1.0
        elif short == "JointModelRevoluteUnaligned":
            sign = float(np.sign(jm.extract().axis[2]))
        else:
            raise UnsupportedJointError(
                f"{path.name}: joint {model.names[j]!r} is a {short}; only revolute joints "
                "about +-z are supported"
            )
        axis_signs.append(sign)
        placement = model.jointPlacements[j]
        if abs(placement.rotation[2, 2] - 1.0) > 1e-9:  # e.g. a tilted fixed joint merged in
            raise UnsupportedJointError(
                f"{path.name}: joint {model.names[j]!r} is placed with a roll/pitch relative to "
                "the previous joint (through a tilted joint origin or fixed joint); a planar "
                "chain allows only yaw rotations"
            )
        yaws.append(_yaw(placement.rotation))
        child.append(np.array(placement.translation[:2]))

    if not model.existFrame(end_effector):
        frames = [f.name for f in model.frames if f.name not in ("universe", "root_joint")]
        raise FrameNotFoundError(
            f"end-effector frame {end_effector!r} not found in {path.name}"
            f"{did_you_mean(end_effector, frames)}; frames: {choices_text(frames)}"
        )
    fid = model.getFrameId(end_effector)
    frame = model.frames[fid]
    ee_body = int(frame.parentJoint) - 1
    if ee_body < 1:
        raise FrameNotFoundError(
            f"end-effector frame {end_effector!r} is attached to the base; it must be on a link"
        )
    rot = frame.placement.rotation
    if abs(rot[2, 2] - 1.0) > 1e-9:
        raise UnsupportedJointError(
            f"{path.name}: end-effector frame {end_effector!r} is tilted out of the plane "
            "(only a yaw is allowed)"
        )

    geometry = PlanarGeometry(
        masses=read_only(np.array(masses)),
        inertias=read_only(np.array(inertias)),
        coms=read_only(np.array(coms)),
        child_joints=read_only(np.array(child)),
        joint_yaws=read_only(np.array(yaws)),
        axis_signs=read_only(np.array(axis_signs)),
        ee_body=ee_body,
        ee_position=read_only(np.array(frame.placement.translation[:2])),
        ee_yaw=_yaw(rot),
    )
    return FreeFloatingRobot(
        model=model,
        urdf_path=path,
        urdf_xml=xml,
        ee_frame=end_effector,
        ee_frame_id=fid,
        geometry=geometry,
        body_names=tuple(body_names),
    )
