"""What differs between a planar and a free-flying root joint, as one table.

Everything else of loading a robot is the same for both (:mod:`.loader`). A :class:`RootJoint`
says which Pinocchio joint carries the base, how a base pose becomes Pinocchio's q, which
checks its URDF needs before Pinocchio reads it, and how the chain's geometry is read.

==============  ===========================  ========================================
root            base pose                    Pinocchio q of the base
==============  ===========================  ========================================
``planar``      (x, y, q_b) [m, m, rad]      (x, y, cos q_b, sin q_b)
``free-flyer``  (x, y, z, s1, s2, s3) [m, MRP]  (x, y, z, qx, qy, qz, qw)
==============  ===========================  ========================================
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..attitude import mrp
from ..errors import ParameterError, UnsupportedJointError
from .geometry import PlanarGeometry, SpatialGeometry, planar_geometry, spatial_geometry

_ANGLE_TOL = 1e-9


def _planar_pose(base_pose) -> np.ndarray:
    x, y, qb = (float(v) for v in base_pose)
    return np.array([x, y, math.cos(qb), math.sin(qb)])


def _free_flyer_pose(base_pose) -> np.ndarray:
    base_pose = np.asarray(base_pose, dtype=float)
    if base_pose.shape != (6,):
        raise ParameterError(
            f"base pose must be (x, y, z, s1, s2, s3) [m, MRP], got shape {base_pose.shape}"
        )
    return np.concatenate((base_pose[:3], mrp.to_quaternion(base_pose[3:])))


def _check_planar_xml(root: ET.Element, source: str) -> None:
    """Joint types, axes and origins of a planar chain, checked on the URDF itself (so the
    message can name the URDF's joint before Pinocchio merges fixed joints)."""
    for joint in root.iter("joint"):
        name = joint.get("name", "?")
        jtype = joint.get("type")
        if jtype == "fixed":
            continue
        if jtype != "revolute":
            raise UnsupportedJointError(
                f"{source}: joint {name!r} has type {jtype!r}; a planar free-floating "
                "manipulator supports only 'revolute' (or 'continuous') joints about z and "
                "'fixed' joints"
            )
        axis_el = joint.find("axis")
        axis_text = "1 0 0" if axis_el is None else axis_el.get("xyz", "1 0 0")
        axis = np.asarray([float(v) for v in axis_text.split()], dtype=float)
        if np.linalg.norm(axis) == 0 or np.linalg.norm(axis[:2]) > 1e-9 * np.linalg.norm(axis):
            raise UnsupportedJointError(
                f"{source}: joint {name!r} has axis {tuple(axis.tolist())}; planar chains "
                "need every revolute axis along +z or -z ('0 0 1' or '0 0 -1')"
            )
        origin = joint.find("origin")
        if origin is not None:
            rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
            if abs(rpy[0]) > _ANGLE_TOL or abs(rpy[1]) > _ANGLE_TOL:
                raise UnsupportedJointError(
                    f"{source}: joint {name!r} origin has roll/pitch {rpy[:2]}; a planar "
                    "chain allows only a yaw (rotation about z) in joint origins"
                )


def _no_xml_check(root: ET.Element, source: str) -> None:
    """Free-flyer roots take any revolute chain; joint kinds are checked on the model."""


@dataclass(frozen=True)
class RootJoint:
    """One row of the root-joint table (see the module docstring).

    Attributes
    ----------
    name : str
        The root's name (base of a scenario).
    joint_model : callable
        Makes Pinocchio's root joint.
    m2 : int
        Position components of the paper's task space (2 planar, 3 spatial).
    m3 : int
        Attitude components of the base (1 planar angle, 3 MRP).
    nq : int
        Entries of the base in Pinocchio's q.
    nv : int
        Entries of the base in Pinocchio's v.
    pose_to_q : callable
        Base pose -> the base's entries of q.
    check_xml : callable
        (URDF element, source) -> None; refuses what the root cannot carry.
    geometry : callable
        (model, ee frame id, body names, source) -> the chain's geometry.
    options : bool
        Locked joints and a satellite body are supported.
    """

    name: str
    joint_model: Callable[[], pin.JointModel]
    m2: int  # position components of the paper's task space (2 planar, 3 spatial)
    m3: int  # attitude components of the base (1 planar angle, 3 MRP)
    nq: int  # entries of the base in Pinocchio's q
    nv: int  # entries of the base in Pinocchio's v
    pose_to_q: Callable[..., np.ndarray]  # base pose -> the base's entries of q
    check_xml: Callable[[ET.Element, str], None]
    # (model, ee frame id, body names, source) -> the chain's geometry
    geometry: Callable[..., PlanarGeometry | SpatialGeometry]
    options: bool  # locked joints and a satellite body are supported


PLANAR = RootJoint(
    name="planar",
    joint_model=pin.JointModelPlanar,
    m2=2,
    m3=1,
    nq=4,
    nv=3,
    pose_to_q=_planar_pose,
    check_xml=_check_planar_xml,
    geometry=planar_geometry,
    options=False,
)
FREE_FLYER = RootJoint(
    name="free-flyer",
    joint_model=pin.JointModelFreeFlyer,
    m2=3,
    m3=3,
    nq=7,
    nv=6,
    pose_to_q=_free_flyer_pose,
    check_xml=_no_xml_check,
    geometry=spatial_geometry,
    options=True,
)

#: root joints by their scenario name (``[robot] base``)
ROOTS: dict[str, RootJoint] = {r.name: r for r in (PLANAR, FREE_FLYER)}
SUPPORTED_BASES = tuple(ROOTS)
