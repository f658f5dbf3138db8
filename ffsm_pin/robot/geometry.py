"""The serial chain's geometry, read from a Pinocchio model and checked.

Bodies are numbered 0..n (0 = the floating base, k = the body moved by joint k). The planar
and spatial geometries hold the same items in their own dimension; the barycentric models are
built from them. The checks here are the ones every free-floating chain needs (positive masses
and physical inertias, revolute joints, a serial chain to the end effector); the checks a
particular root joint adds (planar: axes along +-z) are in :mod:`.roots`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from .._arrays import read_only
from .._docstrings import doc_entries, fill_doc
from ..errors import (
    FrameNotFoundError,
    InertiaError,
    UnsupportedJointError,
    choices_text,
    did_you_mean,
)

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    masses="""
        masses : ndarray, shape (n+1,)
            Body masses [kg].""",
    ee_body="""
        ee_body : int
            Body carrying the end-effector frame (1..n).""",
    source="""
        source : str
            Where the model comes from, for the message.""",
    model="""
        model : pin.Model
            The robot's model.""",
    fid="""
        fid : int
            The end-effector frame.""",
    names="""
        names : tuple of str
            URDF link name of each body 0..n (:func:`body_names`), for the messages.""",
    source_model="""
        source : str
            Where the model comes from, for the messages.""",
    params_model_fid_source=("model", "fid", "source"),
)

_REVOLUTE = {
    "JointModelRX": np.array([1.0, 0.0, 0.0]),
    "JointModelRY": np.array([0.0, 1.0, 0.0]),
    "JointModelRZ": np.array([0.0, 0.0, 1.0]),
}
_JOINT_KINDS = {
    "JointModelPX": "prismatic",
    "JointModelPY": "prismatic",
    "JointModelPZ": "prismatic",
    "JointModelPrismaticUnaligned": "prismatic",
    "JointModelSpherical": "spherical",
    "JointModelSphericalZYX": "spherical",
    "JointModelPlanar": "planar",
    "JointModelFreeFlyer": "floating",
}
_INERTIA_REL_TOL = 1e-9


class _Chain:
    """What every chain geometry answers from its arrays (shared by both dimensions)."""

    masses: np.ndarray
    child_joints: np.ndarray

    @property
    def n_joints(self) -> int:
        """m_1, the number of manipulator joints."""
        return len(self.child_joints)

    @property
    def total_mass(self) -> float:
        """Mass of the whole system [kg]."""
        return float(self.masses.sum())


@dataclass(frozen=True)
@fill_doc(_DOC)
class PlanarGeometry(_Chain):
    """Planar serial chain extracted from a Pinocchio model (bodies 0..n, 0 = base).

    All vectors are 2-D, in the frame of the body they belong to [m].

    Attributes
    ----------
    %(masses)s
    inertias : ndarray, shape (n+1,)
        I_zz about each body CoM [kg m^2].
    coms : ndarray, shape (n+1, 2)
        c_k, CoM in body frame k.
    child_joints : ndarray, shape (n, 2)
        a_k, origin of joint k+1 in body frame k.
    joint_yaws : ndarray, shape (n,)
        Fixed yaw of joint k's placement in its parent [rad].
    axis_signs : ndarray, shape (n,)
        s_j = +1 (axis +z) or -1 (axis -z).
    %(ee_body)s
    ee_position : ndarray, shape (2,)
        e, end-effector origin in body frame ee_body.
    ee_yaw : float
        Yaw of the end-effector frame in body frame ee_body [rad].
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


@dataclass(frozen=True)
@fill_doc(_DOC)
class SpatialGeometry(_Chain):
    """Spatial serial chain extracted from a Pinocchio model (bodies 0..n, 0 = base).

    Body k's frame is the frame of joint k (the base frame for k = 0); vectors are in the
    frame of the body they belong to [m].

    Attributes
    ----------
    %(masses)s
    inertias : ndarray, shape (n+1, 3, 3)
        I_k about the body CoM, body frame [kg m^2].
    coms : ndarray, shape (n+1, 3)
        c_k, CoM in body frame k.
    joint_rotations : ndarray, shape (n, 3, 3)
        Rotation of joint k's placement in body k-1.
    child_joints : ndarray, shape (n, 3)
        a_k, origin of joint k+1 in body frame k.
    axes : ndarray, shape (n, 3)
        Unit axis of joint k in its own frame.
    %(ee_body)s
    ee_position : ndarray, shape (3,)
        e, end-effector origin in body frame ee_body.
    ee_rotation : ndarray, shape (3, 3)
        End-effector frame orientation in body frame ee_body.
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


# ---------------------------------------------------------------------------- checks
def check_inertia(mass: float, inertia: np.ndarray, what: str) -> None:
    """Raise :class:`InertiaError` unless mass > 0 and the 3x3 inertia about the CoM is
    symmetric positive definite and satisfies the triangle inequality of its principal
    moments (I_a + I_b >= I_c, to a relative 1e-9).

    Parameters
    ----------
    mass : float
        Mass [kg].
    inertia : ndarray, shape (3, 3)
        About the CoM [kg m^2].
    what : str
        The body, for the message.
    """
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


@fill_doc(_DOC)
def joint_axis(jm, name: str, source: str) -> np.ndarray:
    """Unit axis of a revolute joint in its own frame; :class:`UnsupportedJointError` naming
    the kind of any other joint.

    Parameters
    ----------
    jm : pin.JointModel
        The joint.
    name : str
        Its name, for the message.
    %(source)s

    Returns
    -------
    ndarray, shape (3,)
        The unit axis.
    """
    short = jm.shortname()
    if short in _REVOLUTE:
        return _REVOLUTE[short].copy()
    if short == "JointModelRevoluteUnaligned":
        axis = np.array(jm.extract().axis, dtype=float)
        return axis / np.linalg.norm(axis)
    kind = _JOINT_KINDS.get(short, short)
    raise UnsupportedJointError(
        f"{source}: joint {name!r} is {kind}; a spatial free-floating manipulator supports only "
        "revolute/continuous and fixed joints (lock it with locked_joints to hold it still)"
    )


def body_names(model: pin.Model) -> tuple[str, ...]:
    """URDF link name of each body 0..n (the joint's name where no body frame is found)."""
    out = []
    for j in range(1, model.njoints):
        names = [
            f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == j
        ]
        out.append(names[0] if names else model.names[j])
    return tuple(out)


@fill_doc(_DOC)
def end_effector_frame(model: pin.Model, name: str, source: str, hint: str = "") -> int:
    """Frame id of the end effector; :class:`FrameNotFoundError` naming the frames there are,
    or when the frame sits on the base.

    Parameters
    ----------
    %(model)s
    name : str
        The frame's name.
    %(source)s
    hint : str
        Appended to the message.

    Returns
    -------
    int
        The frame id.
    """
    if not model.existFrame(name):
        frames = [f.name for f in model.frames if f.name not in ("universe", "root_joint")]
        raise FrameNotFoundError(
            f"end-effector frame {name!r} not found in {source}"
            f"{did_you_mean(name, frames)}{hint}; frames: {choices_text(frames)}"
        )
    fid = model.getFrameId(name)
    if int(model.frames[fid].parentJoint) < 2:
        raise FrameNotFoundError(
            f"end-effector frame {name!r} is attached to the base; it must be on a link"
        )
    return fid


@fill_doc(_DOC)
def check_serial(model: pin.Model, fid: int, source: str, lock_hint: str | None) -> None:
    """Refuse joints that branch off the chain from the base to the end effector.

    ``lock_hint``: None where joints cannot be locked; otherwise the text appended to the list
    of joints to lock (e.g. the usual ones of an example-robot-data arm).

    %(params_model_fid_source)s
    lock_hint : str or None
        None where joints cannot be locked; otherwise the text appended to the list of joints
        to lock.
    """
    branching = [j for j in range(2, model.njoints) if model.parents[j] != j - 1]
    if not branching:
        return
    ee_name = model.frames[fid].name
    text = (
        f"{source}: joint(s) {choices_text(model.names[j] for j in branching)} branch off "
        f"the chain to the end effector {ee_name!r}"
    )
    if lock_hint is None:
        raise UnsupportedJointError(f"{text}; only serial chains are supported")
    on_path = set(model.supports[int(model.frames[fid].parentJoint)])
    off_path = [model.names[j] for j in range(2, model.njoints) if j not in on_path]
    raise UnsupportedJointError(
        f"{text}; lock the joints that are not on it with locked_joints: "
        f"{choices_text(off_path)}{lock_hint}"
    )


# ---------------------------------------------------------------------------- extraction
def _yaw(rotation: np.ndarray) -> float:
    return math.atan2(rotation[1, 0], rotation[0, 0])


def _read_only_arrays(**items: Any) -> dict[str, Any]:
    """The geometry's array fields: each item as a read-only copy (``np.array``)."""
    return {name: read_only(np.array(value)) for name, value in items.items()}


@fill_doc(_DOC)
def planar_geometry(model: pin.Model, fid: int, names: tuple[str, ...], source: str):
    """:class:`PlanarGeometry` of a chain on a planar root; refuses what is not planar.

    Parameters
    ----------
    model : pin.Model
        The robot's model (planar root).
    %(fid)s
    %(names)s
    %(source_model)s
    """
    masses, inertias, coms = [], [], []
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        mass = float(inertia.mass)
        izz = float(inertia.inertia[2, 2])
        if not mass > 0:
            raise InertiaError(
                f"{source}: link {names[j - 1]!r} has mass {mass}; every body of a "
                "free-floating robot needs a positive mass (<inertial><mass>)"
            )
        if not izz > 0:
            raise InertiaError(
                f"{source}: link {names[j - 1]!r} has I_zz = {izz}; every body needs "
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
                f"{source}: joint {model.names[j]!r} is a {short}; only revolute joints "
                "about +-z are supported"
            )
        axis_signs.append(sign)
        placement = model.jointPlacements[j]
        if abs(placement.rotation[2, 2] - 1.0) > 1e-9:  # e.g. a tilted fixed joint merged in
            raise UnsupportedJointError(
                f"{source}: joint {model.names[j]!r} is placed with a roll/pitch relative to "
                "the previous joint (through a tilted joint origin or fixed joint); a planar "
                "chain allows only yaw rotations"
            )
        yaws.append(_yaw(placement.rotation))
        child.append(np.array(placement.translation[:2]))

    frame = model.frames[fid]
    rot = frame.placement.rotation
    if abs(rot[2, 2] - 1.0) > 1e-9:
        raise UnsupportedJointError(
            f"{source}: end-effector frame {frame.name!r} is tilted out of the plane "
            "(only a yaw is allowed)"
        )
    arrays = _read_only_arrays(
        masses=masses, inertias=inertias, coms=coms, child_joints=child, joint_yaws=yaws,
        axis_signs=axis_signs, ee_position=frame.placement.translation[:2],
    )  # fmt: skip
    return PlanarGeometry(**arrays, ee_body=int(frame.parentJoint) - 1, ee_yaw=_yaw(rot))


@fill_doc(_DOC)
def spatial_geometry(
    model: pin.Model, fid: int, names: tuple[str, ...], source: str, base_hint: str = ""
):
    """:class:`SpatialGeometry` of a chain on a free-flyer root.

    ``base_hint`` is appended to an inertia error of the floating base itself.

    Parameters
    ----------
    model : pin.Model
        The robot's model (free-flyer root).
    %(fid)s
    %(names)s
    %(source_model)s
    base_hint : str
        Appended to an inertia error of the floating base.
    """
    axes = [joint_axis(model.joints[j], model.names[j], source) for j in range(2, model.njoints)]
    masses, inertias, coms = [], [], []
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        what = f"{source}: body {names[j - 1]!r}"
        try:
            check_inertia(float(inertia.mass), inertia.inertia, what)
        except InertiaError as exc:
            if j == 1 and base_hint:  # the floating base itself
                raise InertiaError(f"{exc}{base_hint}") from None
            raise
        masses.append(float(inertia.mass))
        inertias.append(np.array(inertia.inertia))
        coms.append(np.array(inertia.lever))
    rotations = [np.array(model.jointPlacements[j].rotation) for j in range(2, model.njoints)]
    child = [np.array(model.jointPlacements[j].translation) for j in range(2, model.njoints)]
    frame = model.frames[fid]
    arrays = _read_only_arrays(
        masses=masses, inertias=inertias, coms=coms, joint_rotations=rotations,
        child_joints=child, axes=axes, ee_position=frame.placement.translation,
        ee_rotation=frame.placement.rotation,
    )  # fmt: skip
    return SpatialGeometry(**arrays, ee_body=int(frame.parentJoint) - 1)
