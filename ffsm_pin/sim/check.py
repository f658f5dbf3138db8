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
from ..control.kinematic import attitude_matrix, error_terms, task_size
from ..control.saturation_feasibility import (
    TorqueFeasibility,
    along_reference,
    reach_acceleration,
    row_map,
    torque_needed,
)
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
    torque : TorqueFeasibility | None
        The torque the funnels and the reference ask of each joint against its limit
        (:func:`torque_feasibility`); None without torque limits.
    """

    name: str
    sigma_min: float | None = None
    threshold: float | None = None
    reach_horizon: float | None = None
    authority: float | None = None
    attitude_error: float | None = None
    problems: list[str] = field(default_factory=list)
    resolved: str | None = None
    torque: TorqueFeasibility | None = None

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
    full = bool(getattr(setup.controller, "needs_dynamics", False))  # a known-model law's M
    meas = Sensor(setup.robot, setup.model, full_model=full).measure(0.0, setup.q0, setup.v0)
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
    torque = torque_feasibility(setup, meas)  # the funnels' torque against the limits
    text = None if torque is None else torque.problem(setup.robot.joint_names)
    if text is not None:
        warnings.warn(text, SaturationWarning, stacklevel=2)
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
    return CheckReport(
        scenario.name, sigma, thr, horizon, authority, att, problems, resolved, torque
    )


#: reference samples over the run of :func:`torque_feasibility`
FEASIBILITY_SAMPLES = 2000
#: configurations along the reference where :func:`torque_feasibility` maps the demand
ALONG_SAMPLES = 400


def torque_feasibility(setup, meas) -> TorqueFeasibility | None:
    """The torque each joint needs for the funnels and the reference, against its limit
    (docs/saturation.md, "The feasibility condition";
    :mod:`~ffsm_pin.control.saturation_feasibility`).

    The funnel rows are the base attitude (unless the controller's scheme is
    ``"no-attitude"`` or the robot has too few joints for it) and the task rows. Their reach
    demand is taken over :data:`FEASIBILITY_SAMPLES` times in (0, duration], their follow
    demand from the reference's acceleration at the same times. The map to joint torques is
    taken at :data:`ALONG_SAMPLES` configurations of a robot that follows the reference from
    the initial one, its errors decaying at the funnels' rates beta
    (:func:`~ffsm_pin.control.saturation_feasibility.along_reference`), with the controller's
    initial estimates (the truth when it has none);
    the worst one is kept. Nothing of the control law is evaluated or compiled.

    Parameters
    ----------
    setup : Setup
        The prepared run (its reference resolved).
    meas : Measurement
        The measurement at t = 0.

    Returns
    -------
    TorqueFeasibility or None
        The numbers; None without finite torque limits.
    """
    limit = None if setup.actuators is None else setup.actuators.limit
    if limit is None or not np.any(np.isfinite(limit)) or setup.funnel_z is None:
        return None
    sc, model = setup.scenario, setup.model
    m3, ref = model.m3, setup.scenario.reference
    n_task = task_size(model.m2, m3, ref.task)
    ctx = getattr(setup.controller, "context", None)
    reads = getattr(setup.controller, "needs_estimates", False)
    est = ctx.estimates if ctx is not None and reads else None
    theta_z, theta_d = (setup.theta_z, setup.theta_d) if est is None else est[:2]
    attitude = getattr(setup.controller, "scheme", None) != "no-attitude"
    attitude = attitude and m3 + n_task <= setup.robot.n_joints

    def maps(q_b, q_m):  # (M*, G, B, L_b) at a configuration, with the estimates
        J_b, J_m = model.jacobians(theta_z, q_b, q_m)
        J = np.hstack((J_b[:n_task], J_m[:n_task]))
        L_b = np.real(attitude_matrix(q_b, m3))
        return (*row_map(model.mass_matrix(theta_d, q_b, q_m), J, L_b, m3, attitude), L_b)

    ts = np.linspace(sc.duration / FEASIBILITY_SAMPLES, sc.duration, FEASIBILITY_SAMPLES)
    z_d = ref.sample(ts)[0]
    at_rest = np.tile(np.asarray(meas.z_e, dtype=float)[:n_task], (ts.size, 1))
    q_bd = np.asarray(ref.base_attitude, dtype=float)
    resting_b = np.tile(np.atleast_1d(meas.q_b), (ts.size, 1))
    d_b, d_z = error_terms(resting_b, q_bd, at_rest, z_d, m3)
    follow_z = np.max(np.abs([ref.ee_accel(t) for t in ts]), axis=0)
    funnels = [("z", setup.funnel_z, d_z, follow_z)]
    if attitude:
        funnels.insert(0, ("b", setup.funnel_b, d_b, np.zeros(m3)))  # q_bd is constant
    rows, reach, follow, t_reach = [], [], [], []
    for name, funnel, d, f in funnels:
        rho = funnel.params.rho(ts[:, None])
        a, t_a = reach_acceleration(d, rho, funnel.lower, funnel.upper, ts)
        rows += [f"{name}{i}" for i in range(a.size)]
        reach.append(a)
        follow.append(f)
        t_reach.append(t_a)
    reach_a, follow_a = np.concatenate(reach), np.concatenate(follow)
    demand = np.maximum(reach_a, follow_a)
    # the reference followed with the errors decaying at the funnels' rates beta
    com = np.asarray(meas.z_e, dtype=float)[: model.m2] - np.real(
        model.ee_offset(theta_z, meas.q_b, meas.q_m)
    )
    beta_b, beta_z = np.array(setup.funnel_b.params.beta), np.array(setup.funnel_z.params.beta)

    def rates(t, q_b, q_m):
        z_e = np.real(model.ee_pose(theta_z, q_b, q_m, com))
        e_b, e_z = error_terms(np.atleast_1d(q_b), q_bd, z_e[:n_task], ref.ee_pose(t), m3)
        task = ref.ee_rate(t) - beta_z * e_z
        return np.concatenate((-beta_b * e_b, task)) if attitude else task

    at = np.linspace(0.0, sc.duration, ALONG_SAMPLES)
    _, mapped = along_reference(maps, rates, meas.q_b, meas.q_m, at)
    shares = [torque_needed(M_star, G, demand) for M_star, G in mapped]
    limit = np.asarray(limit, dtype=float)
    k = int(np.argmax([np.max(share.sum(axis=1) / limit) for share in shares]))
    return TorqueFeasibility(tuple(rows), reach_a, follow_a, np.concatenate(t_reach), shares[k],
                             limit, float(at[k]))  # fmt: skip
