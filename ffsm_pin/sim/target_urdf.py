"""A one-body URDF as the ``[target]`` (issue 40): its link's inertial read into a
:class:`~.target.Target` (docs/capture.md, "A URDF as the target").

Pinocchio reads the URDF with a free-flyer root, so the link's inertial (mass, CoM, inertia
about the CoM, its ``<origin rpy>`` applied) is the root joint's ``pin.Inertia`` in the link
frame, which becomes the target frame. A URDF with joints (more than one body) is refused.
The link's first ``<box>`` geometry (collision, else visual) centred on the link frame with
its axes gives the target its ``size`` (the bus check, the grasp frame's check and the
replay's box); any other geometry gives none (docs/capture.md).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import FfsmError, ScenarioError
from ..robot.urdf import resolve_source
from .target import Target


def target_from_urdf(urdf: str, relative_to: str | None, grasp: pin.SE3) -> Target:
    """The target of a one-body URDF.

    Parameters
    ----------
    urdf : str
        The URDF (a path, relative to ``relative_to``, a shipped name or
        ``example-robot-data:<name>``).
    relative_to : str or None
        The folder a relative path is relative to.
    grasp : pin.SE3
        The grasp frame in the link frame.

    Returns
    -------
    Target
        Its mass, CoM and inertia those of the link's inertial; its size that of a centred
        box geometry (:func:`box_size`), else none.
    """
    path, _ = resolve_source(urdf, relative_to)
    try:
        model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    except (RuntimeError, ValueError) as exc:
        raise ScenarioError(f"target.urdf: {path} cannot be read ({exc})") from None
    if model.njoints != 2:
        bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
        raise ScenarioError(
            f"target.urdf: {path} has {len(bodies)} links ({', '.join(bodies)}); a target is "
            "one body: one link, no joints"
        )
    body = model.inertias[1]
    try:
        return Target(
            body.mass, np.array(body.inertia), grasp=grasp, com=np.array(body.lever),
            size=box_size(str(path)),
        )  # fmt: skip
    except FfsmError as exc:
        raise ScenarioError(f"target.urdf: {path}: its link's inertial: {exc}") from None


def box_size(path: str) -> tuple[float, float, float] | None:
    """The full edge lengths [m] of the URDF's first link's first ``<box>`` geometry
    (``<collision>`` first, then ``<visual>``) when it is centred on the link frame with its
    axes (``<origin>`` absent or zero); None otherwise (no box, a mesh, an offset box).

    Parameters
    ----------
    path : str
        The URDF file.

    Returns
    -------
    tuple of 3 float or None
        The box's ``size``.
    """
    import yourdfpy  # (only a URDF target needs it)

    link = yourdfpy.URDF.load(path, build_scene_graph=False, load_meshes=False).robot.links[0]
    for element in (*link.collisions, *link.visuals):
        box = element.geometry.box
        if box is None:
            continue
        centred = element.origin is None or np.array_equal(element.origin, np.eye(4))
        return (float(box.size[0]), float(box.size[1]), float(box.size[2])) if centred else None
    return None
