"""``load_robot``: URDF -> Pinocchio model on a floating root -> a validated :class:`Robot`.

One pipeline for both roots: find the file, repair its joint limits, let the root joint check
the XML (:mod:`.roots`), add a satellite body, build the Pinocchio model with the root joint
and zero gravity, lock joints, find the end effector, refuse branches, read the geometry.
"""

from __future__ import annotations

import dataclasses
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

import pinocchio as pin

from ..errors import UnsupportedJointError, UrdfError, choices_text, did_you_mean
from .geometry import body_names, check_serial, end_effector_frame
from .native import native_call
from .payload import Payload
from .robot import Robot
from .roots import ROOTS, SUPPORTED_BASES
from .satellite import Satellite
from .urdf import (
    EXAMPLE_ROBOTS,
    UrdfWarning,
    example_robot_name,
    joints_without_effort,
    parse_urdf,
    read_urdf,
    repair_limits,
    resolve_source,
    root_links,
)


def load_robot(
    urdf: str | Path,
    end_effector: str = "ee",
    *,
    base: str = "planar",
    relative_to: str | Path | None = None,
    locked_joints: Mapping[str, float] | None = None,
    satellite: Satellite | Mapping | None = None,
    payload: Payload | Mapping | None = None,
) -> Robot:
    """Load and validate a free-floating manipulator.

    Parameters
    ----------
    urdf : str or Path
        Path to a URDF, the name of a shipped robot (see :func:`shipped_urdfs`), or
        ``"example-robot-data:<name>"`` (names: :data:`EXAMPLE_ROBOTS`).
    end_effector : str
        Name of the end-effector frame (a link or a fixed joint of the URDF).
    base : str
        Root joint: ``"planar"`` (every joint revolute about +-z) or ``"free-flyer"``
        (any revolute chain, spatial).
    relative_to : str or Path or None
        Directory that relative paths are resolved against (e.g. a scenario file's folder).
    locked_joints : mapping of str to float or None
        Free-flyer only: ``{joint name: value}`` [rad or m] of joints held fixed (grippers,
        unused branches).
    satellite : Satellite or Mapping or None
        Free-flyer only: a :class:`Satellite` (or its dict) added as the new root body under
        the URDF's root link, for arm-only URDFs.
    payload : Payload or Mapping or None
        A :class:`Payload` (or its dict) held by the end effector: a rigid body fixed to the
        end-effector frame, added to the body of the frame's joint. The robot's model and
        geometry include it; ``robot.unloaded`` is the robot without it.

    Returns
    -------
    Robot
        With ``robot.root`` the root-joint row and ``robot.geometry`` the chain's geometry.

    Raises
    ------
    RobotFileError, UrdfError, UnsupportedJointError, InertiaError, FrameNotFoundError,
    ParameterError
    """
    if base not in ROOTS:
        raise UnsupportedJointError(
            f"base {base!r} is not supported; valid choices: {choices_text(SUPPORTED_BASES)}"
        )
    root = ROOTS[base]
    if not root.options and (locked_joints or satellite is not None):
        raise UrdfError("options 'locked_joints' and 'satellite' apply only to base 'free-flyer'")
    path, package_dirs = resolve_source(urdf, relative_to)
    source = path.name
    xml, satellite, no_effort = _prepared_xml(read_urdf(path), source, root.check_xml, satellite)
    model = _build_model(xml, root.joint_model(), source)
    model.gravity.setZero()
    locked = {str(k): float(v) for k, v in (locked_joints or {}).items()}
    if locked:
        model = _lock(model, locked, source)
    if model.njoints - 2 < 1:
        raise UrdfError(f"{source}: the robot has no movable joint besides its floating base")

    erd = example_robot_name(urdf)
    hint = ""
    if erd is not None:
        _, ee_hint, lock_hint = EXAMPLE_ROBOTS[erd]
        hint = f" (example-robot-data {erd!r}: end effector {ee_hint!r}"
        hint += f", usually locked: {choices_text(lock_hint)})" if lock_hint else ")"
    fid = end_effector_frame(model, end_effector, source, hint)
    check_serial(model, fid, source, hint if root.options else None)
    names = body_names(model)
    extra = {}
    if root.options and satellite is None:
        extra["base_hint"] = (
            "; it is the floating base (for an arm-only URDF, add a satellite body with "
            "satellite=...)"
        )
    geometry = root.geometry(model, fid, names, source, **extra)
    robot = Robot(
        model=model,
        root=root,
        urdf_path=path,
        urdf_xml=xml,
        ee_frame=end_effector,
        ee_frame_id=fid,
        geometry=geometry,
        body_names=names,
        joint_names=tuple(model.names[j] for j in range(2, model.njoints)),
        locked_joints=locked,
        package_dirs=package_dirs,
        no_effort_limit=tuple(j for j in no_effort if j not in locked),
    )
    if payload is None:
        return robot
    if isinstance(payload, Mapping):
        payload = Payload.from_mapping(payload)
    loaded = payload.attach(model, fid)
    return dataclasses.replace(
        robot,
        model=loaded,
        geometry=root.geometry(loaded, fid, names, source),
        payload=payload,
        unloaded=robot,
    )


def _build_model(xml: str, joint_model, source: str) -> pin.Model:
    """``pin.buildModelFromXML`` with what urdfdom prints captured: an ``Error:`` it prints
    (it may still return a model, e.g. with a mass it could not read set to zero) is a
    :class:`UrdfError` quoting it in one line; other output is one :class:`UrdfWarning`."""
    call = native_call(pin.buildModelFromXML, xml, joint_model)
    said, told = call.output, call.output.summary()
    if call.failure is not None:
        also = f" (urdfdom: {told})" if told and told not in call.failure else ""
        raise UrdfError(f"{source}: Pinocchio cannot parse this URDF: {call.failure}{also}")
    if said.has_errors:
        raise UrdfError(f"{source}: Pinocchio's URDF parser (urdfdom) reports: {told}")
    if told:
        warnings.warn(f"{source}: Pinocchio's URDF parser says: {told}", UrdfWarning, stacklevel=3)
    return call.value


def _prepared_xml(
    text: str, source: str, check_xml, satellite
) -> tuple[str, Satellite | None, tuple[str, ...]]:
    """The URDF text Pinocchio reads (limits repaired, checked for the root, a satellite added;
    the original text when nothing changed), the satellite, and the joints whose file gives no
    effort limit (before the repair invents one)."""
    xml_root = parse_urdf(text, source)
    no_effort = joints_without_effort(xml_root)
    changed = repair_limits(xml_root, source)
    check_xml(xml_root, source)
    roots = root_links(xml_root)
    if len(roots) != 1:
        raise UrdfError(
            f"{source}: the URDF must have a single root link (the floating base), found "
            f"{len(roots)}: {choices_text(roots)}"
        )
    if satellite is not None:
        if isinstance(satellite, Mapping):
            satellite = Satellite.from_mapping(satellite)
        satellite.add_to(xml_root, roots[0], source)
        changed = True
    xml = ET.tostring(xml_root, encoding="unicode") if changed else text
    return xml, satellite, no_effort


def _lock(model: pin.Model, locked: dict[str, float], source: str) -> pin.Model:
    """The model with ``locked`` joints held at their values (``pin.buildReducedModel``)."""
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
    reduced = pin.buildReducedModel(model, sorted(ids), q_ref)
    reduced.gravity.setZero()
    return reduced


def load_spatial_robot(
    urdf: str | Path,
    end_effector: str,
    *,
    relative_to: str | Path | None = None,
    locked_joints: Mapping[str, float] | None = None,
    satellite: Satellite | Mapping | None = None,
) -> Robot:
    """``load_robot(..., base="free-flyer")`` (kept for the spatial loader's callers).

    Parameters
    ----------
    urdf, end_effector, relative_to, locked_joints, satellite
        As :func:`load_robot`'s.

    Returns
    -------
    Robot
        The robot (free-flyer root).
    """
    return load_robot(
        urdf,
        end_effector,
        base="free-flyer",
        relative_to=relative_to,
        locked_joints=locked_joints,
        satellite=satellite,
    )
