"""One robot class for planar and free-flying roots."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import ParameterError
from .geometry import PlanarGeometry, SpatialGeometry
from .payload import Payload
from .roots import RootJoint


@dataclass(frozen=True)
class Robot:
    """A validated free-floating robot: Pinocchio model, its root joint and its geometry.

    Attributes
    ----------
    model : pin.Model
        Pinocchio model, gravity zero, the root joint first (``root.joint_model``).
    root : RootJoint
        The root-joint row (:data:`ffsm_pin.robot.roots.ROOTS`): planar or free-flyer.
    geometry : PlanarGeometry or SpatialGeometry
        :class:`PlanarGeometry` or :class:`SpatialGeometry` of the serial chain.
    urdf_xml : str
        The (possibly repaired or extended) URDF text given to Pinocchio.
    no_effort_limit : tuple of str
        Manipulator joints whose URDF gives no effort limit (no ``<limit>``, or one without
        ``effort``): the model's effort limit of these joints is a placeholder the URDF repair
        wrote for Pinocchio's parser, never a torque limit (:attr:`effort_limits`).
    payload : Payload or None
        A :class:`~ffsm_pin.robot.payload.Payload` held by the end effector, or None. The
        model and the geometry include it (the plant's robot); :attr:`unloaded` is the robot
        without it.
    urdf_path : Path
        The URDF file.
    ee_frame : str
        Name of the end-effector frame.
    ee_frame_id : int
        Its frame id in :attr:`model`.
    body_names : tuple of str
        URDF link name of each body 0..n.
    joint_names : tuple of str
        Manipulator joints 1..n.
    locked_joints : mapping of str to float
        Joints locked at an angle [rad], by name.
    package_dirs : tuple of Path
        Where ``package://`` mesh paths resolve.
    unloaded : Robot or None
        The robot without its payload (None without a payload).
    """

    model: pin.Model
    root: RootJoint
    urdf_path: Path
    urdf_xml: str
    ee_frame: str
    ee_frame_id: int
    geometry: PlanarGeometry | SpatialGeometry
    body_names: tuple[str, ...]  # URDF link name of each body 0..n
    joint_names: tuple[str, ...]  # manipulator joints 1..n
    locked_joints: Mapping[str, float] = field(default_factory=dict)
    package_dirs: tuple[Path, ...] = ()  # where package:// mesh paths resolve
    no_effort_limit: tuple[str, ...] = ()  # joints without <limit effort> in the file
    payload: Payload | None = None  # held by the end effector, included in model and geometry
    unloaded: Robot | None = field(default=None, repr=False, compare=False)  # without payload

    @property
    def estimated(self) -> Robot:
        """The robot a controller's estimates are made from: this one, or :attr:`unloaded`
        when the payload is not known to the controller (``payload.known`` false)."""
        if self.payload is not None and not self.payload.known and self.unloaded is not None:
            return self.unloaded
        return self

    @property
    def effort_limits(self) -> np.ndarray:
        """Each manipulator joint's URDF ``<limit effort>`` [N m], shape (n_joints,); NaN for
        the joints of :attr:`no_effort_limit` (the file gives none)."""
        effort = np.array(self.model.effortLimit, dtype=float)[-self.n_joints :]
        missing = [name in self.no_effort_limit for name in self.joint_names]
        effort[np.asarray(missing, dtype=bool)] = np.nan
        return effort

    @property
    def base(self) -> str:
        """The root joint's name: ``"planar"`` or ``"free-flyer"``."""
        return self.root.name

    @property
    def n_joints(self) -> int:
        """m_1, the number of manipulator joints."""
        return self.geometry.n_joints

    @property
    def name(self) -> str:
        """The robot's name (the URDF's ``<robot name>``)."""
        return self.model.name

    def neutral(self) -> np.ndarray:
        """Neutral configuration q (base at the origin, identity attitude, joints at zero)."""
        return pin.neutral(self.model)

    def configuration(self, base_pose, joints) -> np.ndarray:
        """Pinocchio q from a base pose and joint angles [rad].

        The base pose is (x, y, q_b) [m, m, rad] on a planar root and
        (x, y, z, s1, s2, s3) [m, MRP] on a free-flyer root.

        Parameters
        ----------
        base_pose : array_like
            (x, y, q_b) planar, (x, y, z, s1, s2, s3) free-flyer.
        joints : array_like, shape (n,)
            Joint angles [rad].

        Returns
        -------
        ndarray, shape (nq,)
            q (Pinocchio convention).
        """
        joints = np.asarray(joints, dtype=float)
        base_q = self.root.pose_to_q(base_pose)
        if joints.shape != (self.n_joints,):
            raise ParameterError(
                f"expected {self.n_joints} joint angles for {self.name!r}, got {joints.shape}"
            )
        return np.concatenate((base_q, joints))
