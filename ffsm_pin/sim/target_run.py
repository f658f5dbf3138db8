"""The target in a run (issue 40, first slice): built from ``[target]``, kept clear of the bus,
stepped torque-free once per control period, recorded, and its momentum in the summary.

The robot does not touch the target in this slice (no approach, no capture, no wheels:
docs/capture.md). :func:`build_target` makes the :class:`~.target.Target` box and its initial
:class:`~.target.TargetState`; :func:`check_clear_of_bus` refuses a target overlapping the
bus at t = 0; :class:`TargetMotion` is the loop's per-step work (:mod:`.loop`): it records the
target's pose and twist and advances it by :func:`~.target.torque_free_step` with the run's
initial angular momentum; :func:`target_summary` gives the summary's momentum drifts.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np
import pinocchio as pin

from .._docstrings import fill_doc
from ..errors import ScenarioError
from ..scenario.target_spec import TargetSpec
from ._docs import SIM_DOC
from .target import Target, TargetState, torque_free_step
from .target_urdf import target_from_urdf

#: The per-step signals of a run with a target (shape of one row): the target frame's pose
#: (position [m], quaternion x, y, z, w) and twist (CoM velocity, world [m/s]; body angular
#: velocity [rad/s]).
TARGET_SIGNALS: dict[str, tuple[int, ...]] = {"target_pose": (7,), "target_twist": (6,)}
_ROOT_JOINT = 1  # Pinocchio index of the floating root joint (the bus)


def build_target(spec: TargetSpec, hand_position) -> tuple[Target, TargetState]:
    """The target and its state at t = 0 from ``[target]``.

    Parameters
    ----------
    spec : TargetSpec
        The ``[target]`` table.
    hand_position : array_like, shape (3,)
        The end effector's position at t = 0, world [m] (``origin = "end-effector"``).

    Returns
    -------
    Target
        The box (grasp frame and inertia included).
    TargetState
        Its initial state: ``position`` in the world (the hand's position added for
        ``origin = "end-effector"``), the attitude, CoM velocity and body rates.
    """
    if spec.urdf is not None:  # a one-body URDF: its link's inertial
        grasp = pin.SE3(pin.rpy.rpyToMatrix(*spec.grasp_rpy), np.array(spec.grasp_xyz, float))
        target = target_from_urdf(spec.urdf, spec.relative_to, grasp)
    else:
        assert spec.size is not None and spec.mass is not None  # (the schema's)
        target = Target.box(
            spec.size, spec.mass, spec.inertia, grasp_xyz=spec.grasp_xyz, grasp_rpy=spec.grasp_rpy
        )
    position = np.array(spec.position, dtype=float)
    if spec.origin == "end-effector":
        position = position + np.asarray(hand_position, dtype=float)[:3]
    position = position.tolist()
    state = TargetState.from_rpy(position, spec.attitude_rpy, spec.velocity, spec.angular_velocity)
    return target, state


def boxes_overlap(a: pin.SE3, size_a, b: pin.SE3, size_b) -> bool:
    """Whether two boxes centred on the frames ``a`` and ``b`` overlap (the separating-axis
    test on the 15 axes of two oriented boxes; boxes that only touch do not overlap).

    Parameters
    ----------
    a, b : pin.SE3
        The boxes' frames in the world.
    size_a, size_b : array_like, shape (3,)
        Their edges [m].

    Returns
    -------
    bool
        True when their interiors intersect.
    """
    Ra, Rb = a.rotation, b.rotation
    ha, hb = 0.5 * np.asarray(size_a, float), 0.5 * np.asarray(size_b, float)
    d = b.translation - a.translation
    axes = [*Ra.T, *Rb.T]
    for i in range(3):
        for j in range(3):
            axis = np.cross(Ra[:, i], Rb[:, j])
            if np.linalg.norm(axis) > 1e-12:  # (parallel edges: a face axis covers them)
                axes.append(axis / np.linalg.norm(axis))
    for axis in axes:
        reach = ha @ np.abs(Ra.T @ axis) + hb @ np.abs(Rb.T @ axis)
        if abs(d @ axis) >= reach:
            return False
    return True


def check_clear_of_bus(target: Target, state: TargetState, robot, q0, bus_size=None) -> None:
    """Refuse (one line) a target that overlaps the bus at t = 0.

    With the bus's size known (``[robot.satellite] size``: the satellite link is a box of
    that size centred on the root frame, its visual) the two boxes must not overlap (touching
    is allowed); otherwise (a URDF with its own root body, whose size the package does not
    know) the root frame's origin must lie outside the target's box. A target without a size
    (a URDF target) is checked by its CoM: outside the bus box, when its size is known.

    Parameters
    ----------
    target : Target
        The target (its ``size``).
    state : TargetState
        Its state at t = 0.
    robot : Robot
        The robot (free-flyer root).
    q0 : ndarray
        The robot's initial configuration.
    bus_size : sequence of float or None
        The bus box's edges [m], None if unknown.
    """
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q0)
    bus = data.oMi[_ROOT_JOINT]
    where = np.round(state.pose.translation, 4).tolist()
    size = bus_size
    if target.size is None:  # (a URDF target: its CoM outside the bus box, when known)
        com = bus.actInv(state.com_position(target))
        if size is not None and (np.abs(com) < 0.5 * np.asarray(size)).all():
            raise ScenarioError(
                f"target.position: the target's CoM at {np.round(com, 4).tolist()} m (bus "
                f"frame) is inside the bus (a {list(size)} m box) at t = 0"
            )
        return
    if size is not None:
        if boxes_overlap(bus, size, state.pose, target.size):
            raise ScenarioError(
                f"target.position: the target's box at {where} m overlaps the bus (a "
                f"{list(size)} m box at {np.round(bus.translation, 4).tolist()} m) at t = 0"
            )
        return
    local = state.pose.actInv(bus.translation)
    if (np.abs(local) < 0.5 * np.asarray(target.size)).all():
        raise ScenarioError(
            f"target.position: the target's box at {where} m holds the robot's root frame "
            f"origin {np.round(bus.translation, 4).tolist()} m at t = 0"
        )


@fill_doc(SIM_DOC)
class TargetMotion:
    """The target over a run: its state, stepped torque-free, recorded per row.

    Parameters
    ----------
    %(target_motion)s
    """

    def __init__(self, target: Target, state: TargetState) -> None:
        self.target = target
        self.state = state
        self.momentum = state.angular_momentum(target)  # kept by every step (world, CoM)
        # the CoM's straight line c(0) + v t, kept as the plant keeps the robot's (adding
        # v dt to c at every step biases c by rounding, ~1e-14 m/s: docs/capture.md)
        self.com0 = state.com_position(target)
        self.elapsed = 0.0  # [s] since t = 0

    def write(self, arrays: Mapping[str, np.ndarray], i: int) -> None:
        """Record the current state in row ``i`` of the recorder's ``arrays``.

        Parameters
        ----------
        arrays : mapping of str to ndarray
            The recorder's columns (:data:`TARGET_SIGNALS` among them).
        i : int
            The row.
        """
        s = self.state
        arrays["target_pose"][i] = pin.SE3ToXYZQUAT(s.pose)
        twist = arrays["target_twist"][i]
        twist[:3], twist[3:] = s.velocity, s.angular_velocity

    def advance(self, dt: float) -> None:
        """Step the target ``dt`` [s] torque-free, keeping its initial angular momentum."""
        self.state = self.free_step(dt)

    def free_step(self, dt: float) -> TargetState:
        """The target's state ``dt`` [s] later (:func:`~.target.torque_free_step` keeping its
        initial angular momentum), its CoM put on its line c(0) + v t.

        Parameters
        ----------
        dt : float
            Step [s].

        Returns
        -------
        TargetState
            The state after the step.
        """
        state = torque_free_step(self.target, self.state, dt, self.momentum)
        self.elapsed += dt
        R = state.pose.rotation
        com = self.com0 + self.elapsed * state.velocity
        pose = pin.SE3(R, com - R @ np.array(self.target.com))
        return TargetState(pose, state.velocity, state.angular_velocity)


def target_summary(
    target: Target,
    blocks_of: Callable[[list[str]], Iterable[Mapping[str, np.ndarray]]],
    capture: Any = None,
) -> dict:
    """The summary's target keys from the recorded ``target_pose`` and ``target_twist``.

    ``target_drift_P``: max |P - P0| of P = m v_com [kg m/s]; ``target_drift_L``: max |L - L0|
    of the angular momentum about the world origin, world frame, L = R I w + c x m v_com
    [kg m^2/s]; both over the recorded rows of the free target (every row, or those before
    the capture: once held, the hand changes its momentum).

    Parameters
    ----------
    target : Target
        The body.
    blocks_of : callable
        keys -> consecutive row blocks of the recorded signals
        (:meth:`~.result.RunResult.signals_blocks`).
    capture : CaptureOutcome or None
        The run's capture (:mod:`.capture_run`): rows at or after its ``time`` are not the
        free target's.

    Returns
    -------
    dict
        ``target_drift_P``, ``target_drift_L``.
    """
    inertia, com = np.array(target.inertia), np.array(target.com)
    P0 = L0 = None
    drift_P = drift_L = 0.0
    until = None if capture is None else capture.time  # None: not captured
    for b in blocks_of(["t", *TARGET_SIGNALS]):
        pose, twist = np.asarray(b["target_pose"]), np.asarray(b["target_twist"])
        if until is not None:  # the free phase only
            free = np.asarray(b["t"]) < until
            pose, twist = pose[free], twist[free]
        if not len(pose):
            continue
        P, L = target_momenta(target.mass, inertia, com, pose, twist)
        if P0 is None:
            P0, L0 = P[0], L[0]
        drift_P = max(drift_P, float(np.max(np.linalg.norm(P - P0, axis=1))))
        drift_L = max(drift_L, float(np.max(np.linalg.norm(L - L0, axis=1))))
    return {"target_drift_P": drift_P, "target_drift_L": drift_L}


def target_momenta(mass: float, inertia, com, pose, twist) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the target's linear momentum and angular momentum about the world origin.

    Parameters
    ----------
    mass : float
        [kg].
    inertia : ndarray, shape (3, 3)
        About the CoM, target frame [kg m^2].
    com : ndarray, shape (3,)
        The CoM in the target frame [m].
    pose : ndarray, shape (rows, 7)
        Recorded ``target_pose``.
    twist : ndarray, shape (rows, 6)
        Recorded ``target_twist``.

    Returns
    -------
    P : ndarray, shape (rows, 3)
        m v_com, world [kg m/s].
    L : ndarray, shape (rows, 3)
        R I w + c x m v_com, world, about the world origin [kg m^2/s].
    """
    rows = [pin.XYZQUATToSE3(p) for p in pose]
    R = np.array([m.rotation for m in rows]).reshape(-1, 3, 3)
    c = pose[:, :3] + R @ com
    P = mass * twist[:, :3]
    L = np.einsum("rij,rj->ri", R, twist[:, 3:] @ inertia.T) + np.cross(c, P)
    return P, L
