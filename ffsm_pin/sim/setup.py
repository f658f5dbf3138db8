"""A scenario made concrete: :func:`prepare` builds everything a run needs and checks it.

``prepare(scenario)`` does every check that can fail *before* simulating: first the scenario
schema's, which a scenario built in Python passes like a file
(:func:`~ffsm_pin.scenario.file.check_scenario`: sizes for the robot's root and the task,
ranges, funnels), then what needs the robot itself (its URDF, the controller's own checks,
feasibility, initial errors inside the funnels, the reach horizon). Bad input raises
:class:`~ffsm_pin.errors.FfsmError` subclasses. The loop that runs a :class:`Setup` is
:mod:`ffsm_pin.sim.loop`.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..control.funnel import Funnel
from ..control.gains import GainWarning
from ..control.interface import (
    Controller,
    ControllerContext,
    ReferenceSample,
)
from ..control.kinematic import task_errors, task_size
from ..control.registry import controller_class
from ..errors import (
    ControllerLoadError,
    FfsmError,
    ParameterError,
    ScenarioError,
    choices_text,
    did_you_mean,
)
from ..model import ReducedModel, State, make_model
from ..robot import Robot
from ..scenario.check import check_scenario
from ..scenario.spec import RobotSpec, Scenario
from .actuators import Actuators, urdf_limits
from .approach import Approach, approach_of
from .estimates import initial_estimates
from .initial import initial_state
from .measurement import Sensor
from .reach import ReachWarning, reach_horizon
from .robots import robot_of
from .sensors import Sensors
from .target import Target, TargetState
from .target_run import build_target, check_clear_of_bus


@dataclass
class Setup:
    """A scenario made concrete: robot, models, initial state, truths and controller.

    Attributes
    ----------
    scenario : Scenario
        The scenario.
    robot : Robot
        The plant's robot.
    model : ReducedModel
        Its reduced model.
    q0, v0 : ndarray
        The initial state (Pinocchio convention).
    theta_z, theta_d, theta_b : ndarray
        The true parameters.
    controller : Controller
        Any implementation of :class:`~ffsm_pin.control.interface.Controller`.
    reach_horizon : float or None
        Time the reference leaves the reach [s], None if never.
    events : list of str
        What happened while setting up (warnings).
    actuators : Actuators or None
        Between the controller and the plant (ideal: None).
    sensors : Sensors or None
        Between the plant and the controller (exact: None).
    funnel_b, funnel_z : Funnel or None
        The performance specification, sides fixed at t = 0.
    drawn_estimates : dict
        What the initial estimates were made from (:func:`~.estimates.bodies_record`),
        filled when they are drawn; empty for Table 2, explicit vectors, or estimates never
        read.
    target : Target or None
        The ``[target]`` body (:mod:`.target_run`), None without one.
    target_state : TargetState or None
        Its state at t = 0 (``origin = "end-effector"`` resolved).
    approach : Approach or None
        ``[approach]``, or a ``[capture]`` of a position task without one (its post-capture
        hold): the reference the controller reads (:mod:`.approach`); None otherwise.
    """

    scenario: Scenario
    robot: Robot
    model: ReducedModel
    q0: np.ndarray
    v0: np.ndarray
    theta_z: np.ndarray  # true parameters
    theta_d: np.ndarray
    theta_b: np.ndarray
    controller: Controller  # any implementation of control.interface.Controller
    reach_horizon: float | None  # time the reference leaves the reach [s], None if never
    events: list[str]
    actuators: Actuators | None = None  # between the controller and the plant (ideal: None)
    sensors: Sensors | None = None  # between the plant and the controller (exact: None)
    funnel_b: Funnel | None = None  # the performance specification, sides fixed at t = 0
    funnel_z: Funnel | None = None
    # what the initial estimates were made from (sim.estimates.bodies_record), filled when
    # they are drawn; empty for Table 2, explicit vectors, or estimates never read
    drawn_estimates: dict = dataclasses.field(default_factory=dict)
    target: Target | None = None  # [target], stepped torque-free by the loop
    target_state: TargetState | None = None  # at t = 0
    approach: Approach | None = None  # [approach]: the reference the controller reads

    @property
    def n_task(self) -> int:
        """Components of the end-effector task."""
        return task_size(self.model.m2, self.model.m3, self.scenario.reference.task)


# ---------------------------------------------------------------------- prepare
def prepare(
    scenario: Scenario,
    before_controller: Callable[[], None] | None = None,
    robots: Callable[[RobotSpec], Robot] | None = None,
) -> Setup:
    """Load, validate and build everything for ``scenario``; raise FfsmError on bad input.

    Parameters
    ----------
    scenario : Scenario
        The run to prepare.
    before_controller : callable or None
        Called once every check that does not need the controller has passed, right before
        the controller is built (which compiles its kernels on a cold cache): the command
        line says there that it compiles, so that bad input stays one line.
    robots : callable or None
        ``[robot]`` section -> the run's own :class:`~ffsm_pin.robot.Robot`, e.g. a batch's
        :class:`~.robots.SharedRobots`; None: loaded from its URDF (:func:`~.robots.robot_of`).

    Returns
    -------
    Setup
        Everything a run of ``scenario`` needs (:func:`~ffsm_pin.sim.loop.simulate`).
    """
    check_scenario(scenario)  # the file's schema, also for a scenario built in Python
    spec = scenario.robot
    robot = (robot_of if robots is None else robots)(spec)
    # URDF torque limits that the file does not give: refused before the (slow) controller
    if isinstance(limit := scenario.actuators.torque_limit, str) and limit == "urdf":
        urdf_limits(robot.effort_limits, robot.n_joints, robot.joint_names)
    ctrl, ref = scenario.controller, scenario.reference
    cls = controller_class(ctrl.type, scenario.source.parent if scenario.source else None)
    check_params(cls, ctrl.type, ctrl.params)  # the keys its class declares, if it does
    model = make_model(robot)
    m3 = model.m3
    n_task = task_size(model.m2, m3, ref.task)
    check_task = getattr(cls, "check_task", None)  # a controller's early refusal, if any
    if check_task is not None:
        check_task(scenario, robot.n_joints, n_task, m3)
    check_gains = getattr(cls, "check_gains", None)  # a controller's discrete-time conditions
    for problem in check_gains(scenario, m3) if check_gains is not None else ():
        warnings.warn(problem, GainWarning, stacklevel=2)
    q0, v0 = initial_state(robot, scenario.initial)
    st = State(robot).update(q0, v0)
    truth = (
        np.array(model.true_theta_z(st.com_velocity)),
        np.array(model.theta_d),
        np.array(model.true_theta_b(st.angular_momentum)),
    )

    drawn: dict = {}  # what the estimates were made from (estimates.json), once drawn

    def estimates():  # drawn when the controller first reads ctx.estimates
        made = initial_estimates(scenario, model, truth, robot, q0, v0)
        drawn.update(made.record or {})
        return made.theta_z, made.theta_d, made.theta_b

    if getattr(cls, "needs_estimates", False):  # checked before the funnels, as they are read
        estimates = _constant(estimates())
    sensor = Sensor(robot, model, full_model=False)
    meas0 = sensor.measure(0.0, q0, v0)
    target = target_state = None
    if scenario.target is not None:  # beside the robot at t = 0, clear of the bus
        target, target_state = build_target(scenario.target, meas0.z_e[: model.m2])
        bus = getattr(spec.satellite, "size", None)  # [robot.satellite]; else the root origin
        check_clear_of_bus(target, target_state, robot, q0, bus)
    if ref.origin != "absolute":  # relative to the initial pose: resolved, and saved resolved
        ref = ref.resolved(meas0.z_e, meas0.q_b, model.m2)
        scenario = dataclasses.replace(scenario, reference=ref)
    q_bd = np.array(ref.base_attitude, dtype=float)
    err_b, err_z = task_errors(ref, q_bd, 0.0, meas0.q_b, meas0.z_e, m3)
    perf = scenario.performance  # what every run is judged by
    funnels = {"b": Funnel(perf.funnel_b, err_b), "z": Funnel(perf.funnel_z, err_z)}
    for label, key, funnel, err in (
        ("base attitude", "rho_b0", funnels["b"], err_b),
        ("end-effector", "rho_z0", funnels["z"], err_z),
    ):
        if getattr(cls, "needs_funnels", False) and not funnel.inside(0.0, err):
            z0 = np.round(np.atleast_1d(meas0.z_e), 4).tolist()
            qb0 = np.round(np.atleast_1d(meas0.q_b), 4).tolist()
            hint = (
                f"move reference.ee (c terms) toward the initial end-effector pose z_e(0) = {z0}"
                if key == "rho_z0"
                else f"set reference.base_attitude near q_b(0) = {qb0}"
            )
            lo, hi = funnel.bounds(0.0)
            raise ScenarioError(
                f"initial {label} error {np.round(err, 4).tolist()} is not strictly inside its "
                f"funnel at t = 0 (bounds {np.round(lo, 4).tolist()} .. "
                f"{np.round(hi, 4).tolist()}); increase controller.funnel.{key} or {hint}"
            )
    approach, ctl_scenario = approach_of(scenario, ref, target)  # [approach], else scenario
    n = robot.n_joints
    effort = robot.effort_limits  # the arm joints' URDF <limit effort>, NaN where none
    actuators = Actuators(scenario.actuators, n, scenario.dt, effort, robot.joint_names)
    ctx = ControllerContext(
        n_joints=robot.n_joints,
        m2=model.m2,
        m3=m3,
        task=ref.task,
        n_task=n_task,
        dt=scenario.dt,
        params=dict(ctrl.params),
        reference=_reference_function(ctl_scenario.reference),
        base_attitude_reference=q_bd,
        robot=robot,
        model=model,
        initial=meas0,
        scenario=ctl_scenario,
        estimates_source=estimates,
        truth=truth,
        torque_limit=actuators.limit.copy(),  # what a saturation-aware law knows
    )
    if before_controller is not None:
        before_controller()
    controller = _build_controller(cls, ctx, ctrl.type)
    if approach is not None:  # its reference written before each of the controller's periods
        controller = approach.wrap(controller)
    events = []
    horizon = reach_horizon(model, truth[0], st.com_position, scenario.reference, scenario.duration)
    if horizon is not None:
        msg = (
            f"the reference leaves the arm's reach at t = {horizon:.1f} s (the system CoM drifts "
            f"with v_0 = {np.round(truth[0][: model.m2], 4).tolist()} m/s); no controller can "
            "track it "
            "beyond that"
        )
        events.append(msg)
        warnings.warn(msg, ReachWarning, stacklevel=2)
    sensors = Sensors(scenario.sensors, n, m3, model.m2 + m3)
    return Setup(
        scenario, robot, model, q0, v0, *truth, controller, horizon, events,
        None if actuators.ideal else actuators, None if sensors.ideal else sensors,
        funnels["b"], funnels["z"], drawn, target, target_state, approach,
    )  # fmt: skip


def check_params(cls: type, kind: str, params) -> None:
    """Refuse a ``[controller.params]`` key that the controller's class does not declare in
    its ``params_keys`` (docs/controllers.md; nothing is checked for a class without it): one
    line naming the key, the type and the valid keys.

    Parameters
    ----------
    cls : type
        The controller's class.
    kind : str
        Its type name, for the message.
    params : mapping
        The ``[controller.params]`` table.
    """
    accepted = getattr(cls, "params_keys", None)
    if accepted is None:
        return
    accepted = [str(k) for k in accepted]
    for key in params:
        if key not in accepted:
            raise ParameterError(
                f"controller.params.{key}: unknown for controller.type {kind!r}"
                f"{did_you_mean(str(key), accepted)}; valid keys: "
                f"{choices_text(accepted) or 'none'}"
            )


def _constant(value):
    """A function returning ``value``."""
    return lambda: value


def _reference_function(ref):
    """ctx.reference: t -> (z_d, dz_d, ddz_d), task-size arrays."""

    def reference(t: float) -> ReferenceSample:
        return ReferenceSample(ref.ee_pose(t), ref.ee_rate(t), ref.ee_accel(t))

    return reference


def _build_controller(cls: type, ctx: ControllerContext, kind: str) -> Controller:
    """``cls(ctx)``; a user's constructor that fails is bad input (exit 2)."""
    try:
        return cls(ctx)
    except (FfsmError, KeyboardInterrupt):
        raise
    except BaseException as exc:  # sys.exit() in a constructor too: bad input, one line
        raise ControllerLoadError(
            f"controller.type {kind!r}: building {cls.__name__}(ctx) failed "
            f"({type(exc).__name__}: {exc})"
        ) from exc
