"""``--check`` on a run with a ``[target]`` (issue 40): the target reached in time, the impact.

Can the hand reach the target in time, and would the impact exceed the joints' torque limits?

Nothing is simulated but the target: its torque-free motion from t = 0 is predicted
(:func:`~.target.torque_free_step`) and the hand is assumed to follow its reference exactly.
:func:`predict_capture` samples, every :data:`SAMPLE` seconds of the run, the grasp point, the
hand's grasp point on the reference (the ``[reference]``'s, or the ``[approach]`` blend), their
distance and relative speed, and whether the grasp point is within the arm's reach from the
drifting system CoM (the sum of the barycentric |V_k|, as :func:`~.reach.reach_horizon`). The
predicted capture is the first sample within both ``[capture]`` tolerances; the impact there
is estimated with :func:`~.impact.impact` on the arm at its initial configuration, at rest,
the target's grasp frame on the hand's and moving at the predicted relative velocity, and the
joint torques that stop the held target within the position funnel from it
(:func:`_stopping_torque`).
:func:`capture_warnings` turns that into ``--check``'s warning lines. Necessary conditions
under stated simplifications, not a plan: docs/capture.md, "--check on a capture".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .._docstrings import fill_doc
from ..attitude import mrp
from ._docs import SIM_DOC
from .approach import blend, grasp_motion
from .capture_run import hand_grasp
from .impact import capture_model, impact
from .measurement import Sensor
from .setup import Setup
from .target import TargetState, torque_free_step


class CaptureWarning(UserWarning):
    """``--check``: the target cannot be reached in time, or the impact would exceed the
    joints' torque limits."""


#: [s] the prediction's sampling step (a longer run is sampled coarser: at most MAX_SAMPLES)
SAMPLE = 0.01
MAX_SAMPLES = 5000


@dataclass(frozen=True)
class CapturePrediction:
    """The target's predicted motion against the hand's reference (:func:`predict_capture`).

    Attributes
    ----------
    times : ndarray
        Sample times [s].
    distance : ndarray
        Distance between the hand's grasp point on the reference and the grasp point [m].
    speed : ndarray
        Their relative speed [m/s].
    reachable : ndarray of bool
        The grasp point within the arm's reach from the system CoM.
    reach : float
        The arm's reach [m].
    capture_time : float or None
        The first sample within both tolerances (None: none; or no ``[capture]``).
    stopping_torque : ndarray or None
        The arm joints' torques that stop the held target within the position funnel after
        the impact estimated there [N m] (:func:`_stopping_torque`).
    """

    times: np.ndarray
    distance: np.ndarray
    speed: np.ndarray
    reachable: np.ndarray
    reach: float
    capture_time: float | None = None
    stopping_torque: np.ndarray | None = None


def predict_capture(setup: Setup) -> CapturePrediction | None:
    """The prediction of a run with a target (None without one).

    Parameters
    ----------
    setup : Setup
        The prepared run (its target, capture and approach are read).

    Returns
    -------
    CapturePrediction or None
        See the module docstring.
    """
    target, state, spec = setup.target, setup.target_state, setup.scenario.target
    if target is None or state is None or spec is None:
        return None
    sc, model = setup.scenario, setup.model
    meas = Sensor(setup.robot, model, full_model=False).measure(0.0, setup.q0, setup.v0)
    hand = np.zeros(3) if spec.capture is None else np.asarray(spec.capture.hand_xyz, float)
    offset = mrp.to_rotation(meas.z_e[3:6]) @ hand  # at the initial end-effector attitude
    h = max(SAMPLE, sc.duration / MAX_SAMPLES)
    times = np.arange(0.0, sc.duration + 0.5 * h, h)
    ref = sc.reference  # resolved by prepare
    n = times.size
    g, dg, z, dz = (np.zeros((n, 3)) for _ in range(4))
    for i, t in enumerate(times):
        if i:
            state = torque_free_step(target, state, h)
        g[i], dg[i], _ = grasp_motion(target, state)
        z[i], dz[i] = ref.ee_pose(t)[:3] + offset, ref.ee_rate(t)[:3]
        if spec.approach is not None:
            s, ds, _ = blend(t, spec.approach.time)
            z[i], dz[i] = z[i] + s * (g[i] - z[i]), dz[i] + ds * (g[i] - z[i]) + s * (dg[i] - dz[i])
    distance = np.linalg.norm(g - z, axis=1)
    speed = np.linalg.norm(dg - dz, axis=1)
    reach = float(np.sum(np.linalg.norm(model.barycentric_V, axis=1)))  # type: ignore[attr-defined]
    com = setup.theta_z[None, :3] * times[:, None] + _com(setup)
    reachable = np.linalg.norm(g - com, axis=1) <= reach
    if spec.capture is None:
        return CapturePrediction(times, distance, speed, reachable, reach)
    tol = spec.capture
    ok = np.flatnonzero((distance <= tol.tolerance_position) & (speed <= tol.tolerance_velocity))
    if not ok.size:
        return CapturePrediction(times, distance, speed, reachable, reach)
    i = int(ok[0])
    joint = _stopping_torque(setup, float(times[i]), dg[i] - dz[i])
    return CapturePrediction(times, distance, speed, reachable, reach, float(times[i]), joint)


def _com(setup: Setup) -> np.ndarray:
    """The system CoM at t = 0 [m]."""
    data = setup.robot.model.createData()
    return np.asarray(pin.centerOfMass(setup.robot.model, data, setup.q0)).copy()


def _stopping_torque(setup: Setup, t: float, relative: np.ndarray) -> np.ndarray:
    """The arm joints' torques that stop the held target within the position funnel.

    The weld impact (:func:`~.impact.impact`) with the arm at its initial configuration and
    at rest, the target's grasp frame on the hand's, its grasp point moving at ``relative``
    [m/s] and the target turning at its predicted rate at ``t``, leaves the hand moving at
    dv. Stopping it within the narrowest side of the position funnel at ``t``, rho, takes a
    deceleration |dv|^2 / (2 rho); on the target's mass that is a force F against dv at the
    hand, and J^T F the arm joints' torques (J the hand's translation Jacobian).
    """
    target, spec, funnel = setup.target, setup.scenario.target, setup.funnel_z
    assert target is not None and spec is not None and spec.capture is not None
    state = setup.target_state
    assert state is not None and funnel is not None
    steps = int(np.ceil(t / SAMPLE))
    for _ in range(steps):
        state = torque_free_step(target, state, t / steps)
    cap = capture_model(setup.robot, target, hand_grasp(spec.capture))
    data = cap.model.createData()
    at_rest = np.zeros(setup.robot.model.nv)
    pin.framesForwardKinematics(cap.model, data, cap.joint_state(setup.q0, at_rest, state)[0])
    pose = data.oMf[cap.hand_frame] * target.grasp.inverse()  # the grasp frame on the hand's
    r = pose.rotation @ (target.grasp.translation - np.asarray(target.com))
    spin = pose.rotation @ np.asarray(state.angular_velocity)
    moved = TargetState(pose, relative - np.cross(spin, r), state.angular_velocity)
    q, v_minus = cap.joint_state(setup.q0, at_rest, moved)
    v_plus = impact(cap, q, v_minus).v
    pin.computeJointJacobians(cap.model, data, q)
    J = pin.getFrameJacobian(cap.model, data, cap.hand_frame, pin.LOCAL_WORLD_ALIGNED)[:3]
    dv = J @ v_plus
    speed = float(np.linalg.norm(dv))
    side = np.minimum(np.abs(funnel.lower), np.abs(funnel.upper))
    rho = float(np.min(side * np.asarray(funnel.rho(np.array([[t]])))[0]))
    force = -target.mass * speed / (2.0 * rho) * dv  # |F| = m |dv|^2 / (2 rho), against dv
    n, nv = setup.robot.n_joints, setup.robot.model.nv
    return (J.T @ force)[nv - n : nv]


def capture_warnings(setup: Setup) -> list[str]:
    """``--check``'s warning lines about the target (none without one).

    Parameters
    ----------
    setup : Setup
        The prepared run, as ``--check`` prepares it.

    Returns
    -------
    list of str
        The grasp point beyond the arm's reach over the whole run; the capture tolerances
        never met on the predicted motion (with ``[capture]``); the wheels unable to store
        the detumble's momentum (:func:`wheel_warnings`); the joint torques that stop the
        target within the position funnel after the predicted capture beyond a joint's
        limit.
    """
    pred = predict_capture(setup)
    if pred is None:
        return []
    out = []
    if not pred.reachable.any():
        out.append(
            f"target out of reach: its grasp point stays beyond the arm's reach ({pred.reach:.3g}"
            " m from the system CoM) over the whole run; start it nearer (target.position)"
        )
    spec = setup.scenario.target
    assert spec is not None
    if spec.capture is None:
        return out
    out += wheel_warnings(setup, pred.capture_time)
    tol = spec.capture
    if pred.capture_time is None:
        near = int(np.argmin(pred.distance))
        out.append(
            f"no capture predicted: the hand's reference comes within {pred.distance[near]:.3g} m"
            f" of the grasp point at best (t = {pred.times[near]:.2f} s, relative speed "
            f"{pred.speed[near]:.3g} m/s) and never within capture.tolerance_position = "
            f"{tol.tolerance_position:g} m and capture.tolerance_velocity = "
            f"{tol.tolerance_velocity:g} m/s; give an [approach] or move the target"
        )
        return out
    i = int(np.searchsorted(pred.times, pred.capture_time))
    if not pred.reachable[i]:
        out.append(
            f"target out of reach at the predicted capture (t = {pred.capture_time:.2f} s): "
            f"the grasp point is beyond the arm's reach ({pred.reach:.3g} m)"
        )
    limit = setup.actuators.limit if setup.actuators is not None else None
    if limit is not None and pred.stopping_torque is not None:
        need = np.abs(pred.stopping_torque)
        over = np.flatnonzero(need > limit)
        if over.size:
            j = int(over[np.argmax(need[over] / limit[over])])
            out.append(
                f"impact beyond the torque limits: stopping the target within the position "
                f"funnel after the predicted capture (t = {pred.capture_time:.2f} s) takes "
                f"{need[j]:.3g} N m at joint {setup.robot.joint_names[j]!r}, beyond its limit "
                f"of {limit[j]:.3g} N m; slow the approach (capture.tolerance_velocity, a "
                "longer approach.time) or widen controller.funnel.rho_z*"
            )
    return out


@fill_doc(SIM_DOC)
def detumble_need(setup: Setup) -> np.ndarray | None:
    """The wheel momenta [N m s] that hold the whole system's angular momentum when it is at
    rest at the desired bus attitude after the capture (None without wheels or
    ``[capture]``).

    L, robot and target about their common CoM (world frame), is kept through the run and
    the impact; the wheels start empty. For the bus, the arm and the held target to stop
    turning, the wheels must hold all of it: A h = R_d^T L, R_d the ``reference.base_attitude``
    the bus is brought back to, h = A^+ R_d^T L (:meth:`~ffsm_pin.robot.wheels.Wheels.storing`,
    the allocation of the wheels' attitude PD).

    %(params_setup)s

    Returns
    -------
    ndarray, shape (N,) or None
        h, one per wheel [N m s].
    """
    target, state, spec = setup.target, setup.target_state, setup.scenario.target
    wheels = setup.scenario.robot.wheels
    if wheels is None or target is None or state is None or spec is None or not spec.capture:
        return None
    cap = capture_model(setup.robot, target, hand_grasp(spec.capture))
    momentum = cap.momentum(*cap.joint_state(setup.q0, setup.v0, state))[3:]
    R_d = mrp.to_rotation(np.asarray(setup.scenario.reference.base_attitude, dtype=float))
    return wheels.storing(R_d.T @ momentum)


@fill_doc(SIM_DOC)
def wheel_warnings(setup: Setup, capture_time: float | None = None) -> list[str]:
    """``--check``'s lines when the wheels cannot detumble the system (:func:`detumble_need`):
    some wheel's share beyond its ``max_momentum``, or beyond what its ``max_torque`` can
    store in the time the run has left after the predicted capture.

    A wheel whose torque is limited to tau_max needs at least |h_i| / tau_max seconds to
    store h_i (it starts empty); with the capture predicted at t_c and the run ending at T
    that is possible only when |h_i| <= tau_max (T - t_c): a necessary condition, not a plan
    (the bus, arm and target stop turning only when every wheel holds its share).

    %(params_setup)s
    capture_time : float or None
        t_c [s], the predicted capture (:func:`predict_capture`); None: the torque is not
        checked.

    Returns
    -------
    list of str
        Lines naming ``robot.satellite.wheels.max_momentum`` or
        ``robot.satellite.wheels.max_torque``, or none.
    """
    need = detumble_need(setup)
    wheels = setup.scenario.robot.wheels
    if need is None or wheels is None:
        return []
    out = []
    i = _worst_wheel(np.abs(need) / wheels.max_momentum)
    if i is not None:
        out.append(
            f"wheels too small for the detumble: holding the whole system's angular momentum "
            f"(robot and target, {np.linalg.norm(wheels.momentum_bus(need)):.3g} N m s) at rest "
            f"after the capture takes {abs(need[i]):.3g} N m s on wheel {i}, beyond "
            f"robot.satellite.wheels.max_momentum = {wheels.max_momentum[i]:.3g} N m s; give "
            "larger wheels or a slower target"
        )
    left = setup.scenario.duration - capture_time if capture_time is not None else 0.0
    rate = np.abs(need) / left if left > 0.0 else None  # [N m], the least that stores h in time
    i = None if rate is None else _worst_wheel(rate / wheels.max_torque)
    if rate is not None and i is not None:
        out.append(
            f"wheels too weak for the detumble: storing {abs(need[i]):.3g} N m s on wheel {i} "
            f"in the {left:.3g} s left after the predicted capture (t = {capture_time:.2f} s) "
            f"takes at least {rate[i]:.3g} N m, beyond robot.satellite.wheels.max_torque = "
            f"{wheels.max_torque[i]:.3g} N m; give stronger wheels, a longer run or an earlier "
            "capture"
        )
    return out


def _worst_wheel(ratio: np.ndarray) -> int | None:
    """The wheel furthest beyond its limit (``ratio`` need / limit > 1), None when none is."""
    return int(np.argmax(ratio)) if (ratio > 1.0).any() else None
