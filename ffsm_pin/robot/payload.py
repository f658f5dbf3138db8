"""A payload held by the end effector (``[robot.payload]``): a rigid body fixed to the
end-effector frame."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import ParameterError, check_keys
from .geometry import check_inertia


@dataclass(frozen=True)
class Payload:
    """A rigid body held by the end effector, fixed to the end-effector frame.

    Attributes
    ----------
    mass : float
        Mass [kg].
    inertia : tuple of float
        (ixx, iyy, izz, ixy, ixz, iyz) about its CoM, along the end-effector frame's axes
        [kg m^2].
    com : tuple of float
        Its centre of mass in the end-effector frame [m].
    known : bool
        Whether the controller's estimates include it (default: no; the estimates are then
        made from the robot without it, docs/cli.md ``[robot.payload]``).
    """

    mass: float
    inertia: tuple[float, ...]
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    known: bool = False

    def __post_init__(self) -> None:
        for key, n in (("inertia", 6), ("com", 3)):
            value = tuple(float(x) for x in getattr(self, key))
            if len(value) != n:
                raise ParameterError(f"payload.{key}: expected {n} numbers, got {value}")
            object.__setattr__(self, key, value)
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "known", bool(self.known))
        check_inertia(self.mass, self.inertia_matrix(), "the payload")

    @classmethod
    def from_mapping(cls, table: Mapping) -> Payload:
        """Build from a dict (e.g. a scenario's ``[robot.payload]`` table); unknown keys are
        errors."""
        check_keys(table, ("mass", "inertia", "com", "known"), "payload")
        return cls(**dict(table))

    def inertia_matrix(self) -> np.ndarray:
        """The 3x3 inertia about the payload's CoM, end-effector frame axes [kg m^2]."""
        xx, yy, zz, xy, xz, yz = self.inertia
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])

    def spatial_inertia(self) -> pin.Inertia:
        """The payload as a Pinocchio inertia in the end-effector frame."""
        return pin.Inertia(self.mass, np.array(self.com), self.inertia_matrix())

    def attach(self, model: pin.Model, ee_frame_id: int) -> pin.Model:
        """A copy of ``model`` whose end-effector link carries the payload: its inertia, moved
        from the end-effector frame to the frame's joint, added to that joint's body
        (``appendBodyToJoint``).

        Parameters
        ----------
        model : pin.Model
            The robot's model.
        ee_frame_id : int
            The end-effector frame.

        Returns
        -------
        pin.Model
            The copy with the payload.
        """
        out = pin.Model(model)
        frame = out.frames[ee_frame_id]
        out.appendBodyToJoint(int(frame.parentJoint), self.spatial_inertia(), frame.placement)
        return out
