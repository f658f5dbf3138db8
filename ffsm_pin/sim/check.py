"""Dry run (``python -m ffsm_pin.sim --check``): what decides whether a run can work.

Nothing is simulated. The checks are necessary conditions estimated at t = 0, not a proof
that the run succeeds: a run that passes may still leave a funnel later.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..attitude import mrp
from ..errors import FfsmError
from ..scenario.spec import Scenario


@dataclass(frozen=True)
class CheckReport:
    """What ``--check`` measured and what speaks against the run.

    Attributes
    ----------
    name : str
        Scenario name.
    sigma_min : float | None
        Smallest singular value of J_m-hat U-hat (or J_m-hat) at t = 0 [-].
    threshold : float | None
        The run's singularity threshold (``controller.singularity.threshold``, the
        performance specification's).
    reach_horizon : float | None
        Time the reference leaves the reach under the CoM drift [s]; None if never.
    authority : float | None
        Spatial only: the base rotation about the error's axis the arm can buy
        (:func:`authority_along`, at most the error) [rad].
    attitude_error : float | None
        Spatial only: rotation angle of the initial base attitude error [rad].
    problems : list[str]
        One line per reason the run cannot work; empty when nothing speaks against it.
    resolved : str | None
        With ``reference.origin = "initial"``: the references resolved against the initial
        pose (base attitude, end-effector reference at t = 0), so that an error the relative
        origin cancels is seen before the run; None otherwise.
    """

    name: str
    sigma_min: float | None = None
    threshold: float | None = None
    reach_horizon: float | None = None
    authority: float | None = None
    attitude_error: float | None = None
    problems: list[str] = field(default_factory=list)
    resolved: str | None = None

    @property
    def ok(self) -> bool:
        """True when no problem was found."""
        return not self.problems


#: [rad of joint motion per rad of base rotation] beyond this the arm is said to fold: the
#: direction is lost (the Panda of 'spatial-realistic' needs 13 along its error, a UR5 in its
#: pose 223, a Kinova 1600; a 1000 times stiffer bus turns the Panda's 13 into 13,000)
MAX_JOINT_PER_BASE = 1000.0
#: [rad] largest joint motion of one step (the step in base rotation shrinks to keep it)
JOINT_STEP = 0.02


@dataclass(frozen=True)
class Reach:
    """How far the arm can turn the base about one axis (:func:`authority_along`).

    Attributes
    ----------
    angle : float
        Base rotation reached [rad] (the angle asked for when nothing stopped it).
    why : str
        What stopped it (``"reaches the joint limit of 'j3'"``, ``"folds"``), or ``""``.
    """

    angle: float
    why: str = ""


def authority_along(
    robot, q0: np.ndarray, axis: np.ndarray, angle: float, step: float = 0.005
) -> Reach:
    """The base rotation about the inertial ``axis`` the arm can buy from ``q0`` [rad].

    With no angular momentum, H_bb w_b + H_bm w_m = 0: the joint motion that turns the base
    about ``axis`` at unit rate with the least joint speed is w_m = -(H_bb^-1 H_bm)^+ axis. It
    is followed from ``q0`` in midpoint steps of ``step`` [rad] of base rotation, or less so
    that no joint moves more than :data:`JOINT_STEP` in one (the base turning with it, so
    H_bb and H_bm are those of each pose; on the Panda the reach is within 1e-3 rad of that of
    steps four times finer) until ``angle`` is reached, a joint reaches
    its URDF limit (located inside the last step), or more than :data:`MAX_JOINT_PER_BASE` rad
    of joint motion would be needed per rad of base rotation (the arm folds: H_bb^-1 H_bm has
    lost that direction). A necessary condition, not a plan: another joint path may do
    better, and angular momentum is ignored.

    Parameters
    ----------
    robot : Robot
        The robot (free-flyer).
    q0 : ndarray
        The start configuration (Pinocchio convention).
    axis : ndarray, shape (3,)
        The rotation axis, inertial frame.
    angle : float
        The rotation asked for [rad].
    step : float
        Base rotation per step [rad].

    Returns
    -------
    Reach
        The angle reached and what stopped it.
    """
    from ..model import State

    n = robot.n_joints
    lo = np.asarray(robot.model.lowerPositionLimit, dtype=float)[-n:]
    hi = np.asarray(robot.model.upperPositionLimit, dtype=float)[-n:]
    state = State(robot)
    v = np.zeros(robot.model.nv)

    def rates(q: np.ndarray) -> np.ndarray:  # joint motion per rad of base rotation
        st = state.update(q, v)
        return -np.linalg.pinv(np.linalg.solve(st.H_bb, st.H_bm)) @ axis

    def moved(q: np.ndarray, w_m: np.ndarray, d: float) -> np.ndarray:
        out = q.copy()
        out[-n:] += d * w_m
        rotation = pin.exp3(d * axis) @ pin.Quaternion(q[3:7]).toRotationMatrix()
        out[3:7] = pin.Quaternion(rotation).coeffs()
        return out

    q = np.array(q0, dtype=float)
    turned = 0.0
    while turned < angle:
        w_m = rates(q)
        speed = float(np.linalg.norm(w_m))
        if speed > MAX_JOINT_PER_BASE:
            return Reach(turned, "folds (H_bb^-1 H_bm loses that direction)")
        d = min(step, angle - turned, JOINT_STEP / max(speed, 1e-12))
        w_mid = rates(moved(q, w_m, d / 2))  # midpoint rule: second order in the step
        q_new = moved(q, w_mid, d)
        beyond = np.flatnonzero((q_new[-n:] < lo) | (q_new[-n:] > hi))
        if beyond.size:  # the limit lies inside this step: where, to the joint's first order
            j = beyond[0]
            bound = lo[j] if q_new[-n + j] < lo[j] else hi[j]
            frac = (bound - q[-n + j]) / (q_new[-n + j] - q[-n + j])
            turned += d * float(np.clip(frac, 0.0, 1.0))
            return Reach(turned, f"reaches the limit of joint {robot.joint_names[j]!r}")
        q = q_new
        turned += d
    return Reach(angle)


def check(scenario: Scenario) -> CheckReport:
    """Build the scenario (``prepare``) and evaluate the t = 0 conditions; never simulates."""
    from ..control.compiled import no_warm_up
    from ..control.gains import GainWarning
    from ..control.saturation import SaturationWarning
    from .capture_check import CaptureWarning, capture_warnings
    from .measurement import Sensor
    from .reach import ReachWarning
    from .setup import prepare

    try:
        with warnings.catch_warnings(record=True) as caught, no_warm_up():
            warnings.simplefilter("ignore", ReachWarning)
            warnings.simplefilter("always", GainWarning)
            setup = prepare(scenario)  # the controller's compiled step is not compiled
    except FfsmError as exc:
        return CheckReport(scenario.name, problems=[str(exc)])
    # gains that violate a discrete-time condition (a warning on a run) are problems here;
    # any other warning is shown as it would have been
    problems: list[str] = [str(w.message) for w in caught if w.category is GainWarning]
    for w in caught:
        if w.category is not GainWarning:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    m3 = setup.model.m3
    meas = Sensor(setup.robot, setup.model, full_model=False).measure(0.0, setup.q0, setup.v0)
    # distance to singularity, for controllers that invert a task Jacobian
    singular_value = getattr(setup.controller, "singular_value", None)
    sigma = None if singular_value is None else float(singular_value(meas))
    thr = float(scenario.performance.singularity_threshold)
    if sigma is not None and not sigma > thr:
        problems.append(
            f"singular start: sigma_min of the task Jacobian at t = 0 is {sigma:.4g} <= "
            f"controller.singularity.threshold = {thr:g} [m]; bend the arm (initial.joints away "
            "from a stretched or folded pose) or lower the threshold (its default, 0.05 m, "
            "suits the paper's planar arm; the shipped spatial cases use 0.01 m)"
        )
    torque_demand = getattr(setup.controller, "torque_demand", None)  # (limits vs funnels)
    demand = None if torque_demand is None else torque_demand(meas)
    if demand is not None:  # a warning: the saturation-aware law is made for it
        warnings.warn(demand, SaturationWarning, stacklevel=2)
    for line in capture_warnings(setup):  # [target]: reach in time, impact (capture_check.py)
        warnings.warn(line, CaptureWarning, stacklevel=2)
    horizon = setup.reach_horizon
    if horizon is not None:
        problems.append(
            f"reference out of reach: it leaves the arm's reach at t = {horizon:.2f} s of "
            f"{scenario.duration:g} s; move reference.ee closer to the base or shorten duration"
        )
    authority = att = None
    if m3 == 3:
        q_bd = np.array(setup.scenario.reference.base_attitude, dtype=float)  # resolved
        turn = pin.log3(mrp.to_rotation(q_bd) @ mrp.to_rotation(np.asarray(meas.q_b)).T)
        att = float(np.linalg.norm(turn))  # the rotation the base needs [rad], inertial axis
        if att > 1e-9:
            reach = authority_along(setup.robot, setup.q0, turn / att, att)
            authority = reach.angle
            if reach.angle < att:
                problems.append(
                    f"attitude error beyond the arm's authority: the base must turn "
                    f"{att:.3g} rad about {np.round(turn / att, 3).tolist()} (inertial), but "
                    f"moving the arm to turn it that way {reach.why} after {reach.angle:.3g} "
                    "rad; set reference.base_attitude nearer initial.base_attitude, start the "
                    "arm elsewhere or use a lighter satellite / heavier arm"
                )
    resolved = None
    if scenario.reference.origin == "initial":
        ref = setup.scenario.reference  # (prepare resolves it)
        resolved = (
            f"reference.origin = 'initial' resolves to base_attitude = "
            f"{np.round(np.asarray(ref.base_attitude), 4).tolist()}, end-effector reference "
            f"at t = 0 = {np.round(ref.ee_pose(0.0), 4).tolist()} (initial pose: q_b(0) = "
            f"{np.round(np.atleast_1d(meas.q_b), 4).tolist()}, z_e(0) = "
            f"{np.round(np.asarray(meas.z_e)[: ref.n_components], 4).tolist()})"
        )
    return CheckReport(scenario.name, sigma, thr, horizon, authority, att, problems, resolved)
