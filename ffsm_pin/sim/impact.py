"""Capture of a target (issue 40): the robot and the target as one Pinocchio model, the
perfectly plastic 6-D weld impact between the hand's grasp frame and the target's, and the
merged robot after capture (docs/capture.md).

* :func:`capture_model`: the robot's model plus the target as a second free-flyer body under
  the universe, with a frame for each grasp (:class:`CaptureModel`).
* :func:`impact`: the post-impact velocity by the impulse formula
  ``v+ = v- + M^-1 J^T lambda``, ``lambda = -(J M^-1 J^T)^-1 J v-``, J the weld's Jacobian
  (relative twist of the two grasp frames, hand frame); :func:`impact_pinocchio`: the same
  from Pinocchio's ``impulseDynamics`` with a ``CONTACT_6D`` constraint between the two
  frames (the check).
* :func:`merge_after_capture`: the welded system as ONE robot, the target held by the end
  effector as a :class:`~ffsm_pin.robot.payload.Payload`, and its (q, v).

Capture is for free-flyer robots only: on a planar root the target would need a planar joint
and the weld three rows, and Pinocchio's 6-D constraint could not check them; a planar robot
is refused with one :class:`ParameterError` line.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .._docstrings import doc_entries, fill_doc
from ..errors import ParameterError
from ..robot import Payload, Robot
from .target import Target, TargetState

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    capture="""
        capture : CaptureModel
            The combined model.""",
    q_v_before="""
        q, v : array_like
            Configuration and velocity before the impact.""",
    state="""
        state : TargetState
            The target's state.""",
    q_v_combined="""
        q, v : array_like
            The combined configuration and velocity.""",
    params_capture_q_v_before=("capture", "q_v_before"),
    params_q_v_combined=("q_v_combined",),
)

#: the weld must hold to this (relative twist / largest velocity) before a merge
WELD_TOL = 1e-9


@dataclass(frozen=True)
class CaptureTolerances:
    """When the hand may grasp: the distance between the two grasp frames' origins below
    ``position`` [m] and their relative speed below ``velocity`` [m/s] (both > 0).

    Parameters
    ----------
    position : float
        Distance [m].
    velocity : float
        Relative speed [m/s].
    """

    position: float
    velocity: float

    def __post_init__(self) -> None:
        for key in ("position", "velocity"):
            value = float(getattr(self, key))
            if not (np.isfinite(value) and value > 0):
                unit = "m" if key == "position" else "m/s"
                raise ParameterError(f"capture.tolerance_{key}: must be > 0 {unit}, got {value}")
            object.__setattr__(self, key, value)


@dataclass(frozen=True, eq=False)
@fill_doc(_DOC)
class CaptureModel:
    """The robot and the free target as one Pinocchio model.

    q = (q_robot, q_target), v = (v_robot, v_target): the robot's coordinates first, then the
    target's free-flyer joint (position, quaternion x y z w; the twist of the target frame in
    its own axes), as :meth:`TargetState.to_pinocchio <.target.TargetState.to_pinocchio>`.

    Attributes
    ----------
    robot, target : Robot, Target
        The robot (free-flyer root) and the target.
    model : pin.Model
        The combined model (gravity zero).
    target_joint : int
        The target's joint id in ``model``.
    hand_frame, grasp_frame : int
        Frame ids in ``model`` of the hand's grasp frame (the end-effector frame moved by
        ``hand_grasp``) and of the target's grasp frame.
    hand_grasp : pin.SE3
        The hand's grasp frame in the end-effector frame (``pin.SE3``).
    """

    robot: Robot
    target: Target
    model: pin.Model
    target_joint: int
    hand_frame: int
    grasp_frame: int
    hand_grasp: pin.SE3

    @property
    def nq_robot(self) -> int:
        """Size of the robot's q."""
        return int(self.robot.model.nq)

    @property
    def nv_robot(self) -> int:
        """Size of the robot's v."""
        return int(self.robot.model.nv)

    def joint_state(self, q_robot, v_robot, state: TargetState) -> tuple[np.ndarray, np.ndarray]:
        """The combined (q, v): the robot's, then the target's free-flyer q and twist.

        Parameters
        ----------
        q_robot, v_robot : array_like, shapes (nq_robot,) and (nv_robot,)
            The robot's configuration and velocity (Pinocchio convention).
        %(state)s

        Returns
        -------
        q, v : ndarray
            The combined configuration and velocity.
        """
        q_target, v_target = state.to_pinocchio(self.target)
        return (
            np.concatenate((np.asarray(q_robot, float), q_target)),
            np.concatenate((np.asarray(v_robot, float), v_target)),
        )

    def target_state(self, q, v) -> TargetState:
        """The target's state in the combined (q, v).

        Parameters
        ----------
        q, v : array_like
            The combined configuration and velocity (only the target's entries are read).

        Returns
        -------
        TargetState
            The target's entries.
        """
        return TargetState.from_pinocchio(
            self.target, np.asarray(q)[self.nq_robot :], np.asarray(v)[self.nv_robot :]
        )

    def relative_pose(self, q) -> pin.SE3:
        """The target's grasp frame in the hand's grasp frame."""
        data = self.model.createData()
        pin.framesForwardKinematics(self.model, data, np.asarray(q, float))
        return data.oMf[self.hand_frame].actInv(data.oMf[self.grasp_frame])

    def weld_jacobian(self, q) -> np.ndarray:
        """J (6 x nv): J v is the twist of the hand's grasp frame minus that of the target's,
        both at the hand's grasp frame, in its axes (linear; angular). J = J_hand -
        X(hMg) J_grasp, the frame Jacobians in their own (LOCAL) frames, X the action matrix
        of the grasp frame's pose in the hand's; the weld is J v = 0."""
        model, data = self.model, self.model.createData()
        q = np.asarray(q, float)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        J_hand = pin.getFrameJacobian(model, data, self.hand_frame, pin.LOCAL)
        J_grasp = pin.getFrameJacobian(model, data, self.grasp_frame, pin.LOCAL)
        hMg = data.oMf[self.hand_frame].actInv(data.oMf[self.grasp_frame])
        return J_hand - hMg.action @ J_grasp

    def relative_twist(self, q, v) -> np.ndarray:
        """J v (:meth:`weld_jacobian`): hand minus target at the hand's grasp frame [m/s, rad/s].

        %(params_q_v_combined)s

        Returns
        -------
        ndarray, shape (6,)
            The relative twist (linear first).
        """
        return self.weld_jacobian(q) @ np.asarray(v, float)

    def relative_motion(self, q, v) -> tuple[float, float]:
        """(distance [m] between the two grasp frames' origins, relative speed [m/s] of the two
        bodies at the hand's grasp point): what :meth:`ready` compares with the tolerances.

        %(params_q_v_combined)s

        Returns
        -------
        distance, speed : float
            [m] and [m/s].
        """
        return (
            float(np.linalg.norm(self.relative_pose(q).translation)),
            float(np.linalg.norm(self.relative_twist(q, v)[:3])),
        )

    def ready(self, q, v, tolerances: CaptureTolerances) -> bool:
        """Whether the hand may grasp: distance and relative speed within the tolerances.

        Parameters
        ----------
        %(q_v_combined)s
        tolerances : CaptureTolerances
            Distance [m] and relative speed [m/s] allowed.

        Returns
        -------
        bool
            True when both are within the tolerances.
        """
        distance, speed = self.relative_motion(q, v)
        return distance <= tolerances.position and speed <= tolerances.velocity

    def mass_matrix(self, q) -> np.ndarray:
        """The joint-space inertia M(q) (both triangles)."""
        M = pin.crba(self.model, self.model.createData(), np.asarray(q, float))
        return np.triu(M) + np.triu(M, 1).T

    def momentum(self, q, v) -> np.ndarray:
        """(P, L) of robot and target: linear momentum [kg m/s] and angular momentum about the
        system CoM [kg m^2/s], world frame (Pinocchio's centroidal momentum).

        %(params_q_v_combined)s

        Returns
        -------
        ndarray, shape (6,)
            (P, L).
        """
        data = self.model.createData()
        return pin.computeCentroidalMomentum(
            self.model, data, np.asarray(q, float), np.asarray(v, float)
        ).vector.copy()

    def kinetic_energy(self, q, v) -> float:
        """v^T M v / 2 [J].

        %(params_q_v_combined)s

        Returns
        -------
        float
            Kinetic energy [J].
        """
        v = np.asarray(v, float)
        return 0.5 * float(v @ self.mass_matrix(q) @ v)


def capture_model(robot: Robot, target: Target, hand_grasp: pin.SE3 | None = None) -> CaptureModel:
    """The robot (free-flyer root) and ``target`` as one model; the hand's grasp frame is the
    end-effector frame moved by ``hand_grasp`` (default: the end-effector frame itself).

    Parameters
    ----------
    robot : Robot
        A robot with a free-flyer base.
    target : Target
        The target body.
    hand_grasp : pin.SE3 or None
        The hand's grasp frame in the end-effector frame.

    Returns
    -------
    CaptureModel
        The combined model.
    """
    if robot.base != "free-flyer":
        raise ParameterError(
            f"capture: robot {robot.name!r} has a {robot.base!r} base; capture is implemented for "
            "base = 'free-flyer' robots only (docs/capture.md)"
        )
    hand_grasp = pin.SE3.Identity() if hand_grasp is None else pin.SE3(hand_grasp)
    model = pin.Model(robot.model)
    joint = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), target.name)
    model.appendBodyToJoint(joint, target.spatial_inertia(), pin.SE3.Identity())
    body = model.addBodyFrame(target.name, joint, pin.SE3.Identity(), 0)
    grasp = model.addFrame(
        pin.Frame(f"{target.name}_grasp", joint, body, target.grasp, pin.FrameType.OP_FRAME)
    )
    ee = robot.model.frames[robot.ee_frame_id]
    hand = model.addFrame(
        pin.Frame(
            "hand_grasp",
            ee.parentJoint,
            robot.ee_frame_id,
            ee.placement * hand_grasp,
            pin.FrameType.OP_FRAME,
        )
    )
    model.gravity.setZero()
    return CaptureModel(robot, target, model, joint, hand, grasp, hand_grasp)


class Impact(NamedTuple):
    """The result of a perfectly plastic weld impact."""

    v: np.ndarray  # the combined model's velocity after the impact
    impulse: np.ndarray  # (6,) on the hand at its grasp frame, its axes: [N s] linear, [N m s]
    energy_loss: float  # kinetic energy lost [J] (>= 0)


@fill_doc(_DOC)
def impact(capture: CaptureModel, q, v) -> Impact:
    """The weld impact by the impulse formula: with M = M(q) and J = :meth:`weld_jacobian
    <CaptureModel.weld_jacobian>`, lambda = -(J M^-1 J^T)^-1 J v-, v+ = v- + M^-1 J^T lambda.
    lambda is the impulse on the hand (the target receives its opposite); J v+ = 0.

    %(params_capture_q_v_before)s

    Returns
    -------
    Impact
        v after it, the impulse on the hand and the energy lost.
    """
    q, v = np.asarray(q, float), np.asarray(v, float)
    M = capture.mass_matrix(q)
    J = capture.weld_jacobian(q)
    chol = np.linalg.cholesky(M)
    Minv_JT = np.linalg.solve(chol.T, np.linalg.solve(chol, J.T))
    impulse = -np.linalg.solve(J @ Minv_JT, J @ v)
    v_plus = v + Minv_JT @ impulse
    return Impact(v_plus, impulse, 0.5 * float(v @ M @ v - v_plus @ M @ v_plus))


@fill_doc(_DOC)
def impact_pinocchio(capture: CaptureModel, q, v) -> Impact:
    """The weld impact by Pinocchio's ``impulseDynamics`` with a ``CONTACT_6D`` constraint
    between the two grasp frames (LOCAL), restitution 0.

    Pinocchio 4.1's impulseDynamics takes the constraint's pre-impact velocity from its first
    frame alone (include/pinocchio/algorithm/impulse-dynamics.hxx), which is right only when
    the second frame is at rest. The call is therefore made in the frame that moves with the
    target: the whole system's velocity minus the rigid motion w of the target (every body
    given the target's spatial velocity), which changes neither J v nor the impulse; w is added
    back to the result.

    %(params_capture_q_v_before)s

    Returns
    -------
    Impact
        As :func:`impact`.
    """
    model, data = capture.model, capture.model.createData()
    q, v = np.asarray(q, float), np.asarray(v, float)
    hand = model.frames[capture.hand_frame]
    grasp = model.frames[capture.grasp_frame]
    constraint = pin.RigidConstraintModel(
        pin.ContactType.CONTACT_6D,
        model,
        hand.parentJoint,
        hand.placement,
        grasp.parentJoint,
        grasp.placement,
        pin.ReferenceFrame.LOCAL,
    )
    models = pin.StdVec_RigidConstraintModel()
    models.append(constraint)
    datas = pin.StdVec_RigidConstraintData()
    datas.append(constraint.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    # the rigid motion that brings the target to rest: the target's spatial velocity (world)
    # given to the robot's root (its joints still) and to the target
    pin.forwardKinematics(model, data, q, v)
    jt = capture.target_joint
    spatial = data.oMi[jt].act(data.v[jt])
    rigid = np.zeros(model.nv)
    rigid[:6] = data.oMi[1].actInv(spatial).vector
    rigid[capture.nv_robot :] = data.v[jt].vector
    settings = pin.ProximalSettings(1e-14, 0.0, 1)
    v_plus = pin.impulseDynamics(model, data, q, v - rigid, models, datas, 0.0, settings) + rigid
    M = capture.mass_matrix(q)
    loss = 0.5 * float(v @ M @ v - v_plus @ M @ v_plus)
    return Impact(np.array(v_plus), np.array(datas[0].contact_force.vector), loss)


@fill_doc(_DOC)
def merge_after_capture(
    capture: CaptureModel, q, v, *, known: bool | None = None
) -> tuple[Robot, np.ndarray, np.ndarray]:
    """The welded system as one robot and its (q, v).

    The target becomes a :class:`~ffsm_pin.robot.payload.Payload` of the end effector at its
    pose relative to the end-effector frame in q (so the grasp frames' offset at capture is
    kept); a payload the robot already held is combined with it (``pin.Inertia`` sum). The
    merged robot's (q, v) are the combined model's robot entries, v after the impact (the
    target then moves with the hand: momentum is unchanged). ``known``: whether the
    controller's estimates include the combined payload (default: as the robot's payload,
    else no). A v in which the weld does not hold is refused.

    Parameters
    ----------
    %(capture)s
    q, v : array_like
        Its configuration and velocity after the impact.
    known : bool or None
        Whether the controller's estimates include the combined payload.

    Returns
    -------
    robot : Robot
        The merged robot.
    q, v : ndarray
        Its configuration and velocity.
    """
    q, v = np.asarray(q, float), np.asarray(v, float)
    twist = capture.relative_twist(q, v)
    scale = max(float(np.abs(v).max()), 1e-300)
    if np.abs(twist).max() > WELD_TOL * scale:
        raise ParameterError(
            f"merge_after_capture: the hand and the target still move apart (relative twist "
            f"{np.abs(twist).max():.3g}); merge the velocity after the impact"
        )
    robot = capture.robot
    data = capture.model.createData()
    pin.framesForwardKinematics(capture.model, data, q)
    eeMt = data.oMf[robot.ee_frame_id].actInv(data.oMi[capture.target_joint])
    inertia = eeMt.act(capture.target.spatial_inertia())  # in the end-effector frame
    base = robot
    if robot.payload is not None and robot.unloaded is not None:
        inertia = robot.payload.spatial_inertia() + inertia
        base = robot.unloaded
    if known is None:
        known = robot.payload.known if robot.payload is not None else False
    Ic = inertia.inertia
    payload = Payload(
        mass=inertia.mass,
        inertia=(Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2]),
        com=tuple(inertia.lever),  # type: ignore[arg-type]  # three numbers
        known=known,
    )
    model = payload.attach(base.model, base.ee_frame_id)
    merged = dataclasses.replace(
        base,
        model=model,
        geometry=base.root.geometry(model, base.ee_frame_id, base.body_names, base.urdf_path.name),
        payload=payload,
        unloaded=base,
    )
    return merged, q[: capture.nq_robot].copy(), v[: capture.nv_robot].copy()
