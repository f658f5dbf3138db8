"""The sections of the scenario file (docs/cli.md) as pydantic v2 models.

One model per table (``[robot]``, ``[initial]``, ``[reference]``, ``[controller]`` and its
subtables, ``[sim]``, ``[actuators]``, ``[sensors]``, ``[target]``, ``[capture]``): its keys
(``extra="forbid"``), their types (strict: a string is no number, a boolean no integer; an
integer is accepted for a number), lengths, ranges and choices, and the checks within the
table. The whole file, and the checks across tables, is
:class:`ffsm_pin.scenario.schema.ScenarioModel`. The defaults are read from the dataclasses
(:mod:`ffsm_pin.scenario.spec`); the value types are those of
:mod:`ffsm_pin.scenario.values`.
"""

# mypy: disable-error-code="valid-type"
# (the field types are built at run time, vec(n) and Literal over tables; pydantic checks them)

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BeforeValidator,
    Field,
    field_validator,
    model_validator,
)

from .._schema import Num, Pos, Table, Vec, default, fail
from ..control.kinematic import TASKS
from ..control.lu_jia_params import LuJiaKeys, LuJiaSingularityKeys
from ..errors import InertiaError, choices_text
from ..robot.geometry import check_inertia
from ..robot.payload import Payload
from ..robot.satellite import Satellite
from .devices import ActuatorSpec, SensorSpec
from .spec import (
    ESTIMATE_KINDS,
    INTEGRATORS,
    ORIGINS,
    ControllerSpec,
    Estimates,
    Performance,
    Reference,
    RobotSpec,
    Scenario,
)
from .target_spec import (
    CAPTURE_ESTIMATES,
    TARGET_ORIGINS,
    TARGET_SHAPES,
    ApproachSpec,
    CaptureSpec,
    TargetSpec,
)
from .values import (
    Fraction,
    NonNeg,
    NonNegOrVec,
    NumOrVec,
    Sigma,
    _pairs,
    _tables,
    _torque_limit,
    or_list,
    vec,
)
from .wheels_spec import WheelsModel

#: For each supported base: (m2 end-effector position components, m3 attitude components).
TASK_SIZE = {"planar": (2, 1), "free-flyer": (3, 3)}
MAX_STEPS = 1e12  # control steps of a run (sim.duration / sim.dt): more is no run at all


# ------------------------------------------------------------------------------ sections
class SatelliteModel(Table):
    """``[robot.satellite]``, :class:`~ffsm_pin.robot.Satellite` (defaults there)."""

    mass: Pos = default(Satellite, "mass")  # [kg]
    inertia: vec(6) = default(Satellite, "inertia")  # [kg m^2]
    size: vec(3) = default(Satellite, "size")  # [m]
    mount_xyz: vec(3) = default(Satellite, "mount_xyz")  # [m]
    mount_rpy: vec(3) = default(Satellite, "mount_rpy")  # [rad]
    name: str = default(Satellite, "name")
    wheels: WheelsModel | None = None  # reaction wheels on the bus (scenario/wheels_spec.py)


class PayloadModel(Table):
    """``[robot.payload]``, :class:`~ffsm_pin.robot.Payload`: a rigid body held by the end
    effector (com and inertia in the end-effector frame)."""

    mass: Pos  # [kg]
    com: vec(3) = default(Payload, "com")  # [m], end-effector frame
    inertia: vec(6)  # ixx, iyy, izz, ixy, ixz, iyz about its CoM [kg m^2]
    known: bool = default(Payload, "known")  # in the controller's estimates

    @model_validator(mode="after")
    def physical(self):
        """Refuse an inertia no rigid body has."""
        xx, yy, zz, xy, xz, yz = self.inertia
        try:
            check_inertia(
                self.mass, np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]), "the payload"
            )
        except InertiaError as exc:
            fail(("inertia",), f" = {list(self.inertia)}: {str(exc).removeprefix('the payload ')}")
        return self


class RobotModel(Table):
    """``[robot]``: the URDF, its root (planar or free-flyer), end effector, satellite."""

    urdf: str = default(RobotSpec, "urdf")
    base: Literal[tuple(TASK_SIZE)] = default(RobotSpec, "base")
    end_effector: str = default(RobotSpec, "end_effector")
    locked_joints: dict[str, Num] = {}  # [rad or m], free-flyer only
    satellite: SatelliteModel | None = None  # free-flyer only
    payload: PayloadModel | None = None  # held by the end effector

    @model_validator(mode="after")
    def spatial_only(self):
        """Refuse locked joints, a satellite body and wheels on a planar robot."""
        if self.satellite is not None and self.satellite.wheels is not None:
            if self.base != "free-flyer":
                fail(("satellite", "wheels"), " apply only to base = 'free-flyer' (spatial)")
        if (self.locked_joints or self.satellite is not None) and self.base != "free-flyer":
            fail(("locked_joints",), " and [robot.satellite] apply only to base = 'free-flyer'")
        return self


def _unit_quaternion(q: list[float]) -> list[float]:
    norm = math.sqrt(sum(x * x for x in q))
    if not abs(norm - 1.0) < 1e-6:
        fail((), f": (x, y, z, w) must have unit norm, got {norm:.6g}")
    return q


class InitialModel(Table):
    """``[initial]``: the initial base pose, joints and rates."""

    base_pose: Vec  # planar x, y, q_b [m, rad]; spatial x, y, z [m] + MRP (or rpy / quaternion)
    base_attitude_rpy: vec(3) | None = None  # [rad], free-flyer only
    base_attitude_quaternion: vec(4) | None = None  # (x, y, z, w), free-flyer only
    com_at_origin: bool = False
    joints: Annotated[Vec, Field(min_length=1)]  # [rad]
    joint_rates: Vec | None = None  # [rad/s], default zeros
    base_twist: Vec | None = None  # [m/s, rad/s]
    com_velocity: Vec | None = None  # [m/s]
    base_rate: NumOrVec | None = None  # [rad/s]
    angular_momentum: NumOrVec | None = None  # [kg m^2/s]
    attitude_error: NumOrVec | None = (
        None  # [rad] on top of base_pose: planar angle, spatial axis*angle
    )

    @field_validator("base_attitude_quaternion")
    @classmethod
    def unit_quaternion(cls, q: list[float] | None) -> list[float] | None:
        """Refuse a quaternion that is not of unit norm."""
        return q if q is None else _unit_quaternion(q)

    @model_validator(mode="after")
    def rates_and_attitude(self):
        """Refuse two initial base attitudes."""
        # the lengths of joints and joint_rates are checked against the robot's joint count
        # where the robot is known (run.initial_state), so the list that is wrong is blamed
        if self.base_attitude_rpy is not None and self.base_attitude_quaternion is not None:
            fail(("base_attitude_rpy",), " and initial.base_attitude_quaternion: give one of them")
        return self


class HarmonicsModel(Table):
    """One entry of ``reference.ee``: c + sum a cos(w t) + sum b sin(w t)."""

    c: Num = 0.0
    cos: Annotated[list[vec(2)], BeforeValidator(_pairs)] = []  # [[amplitude, w [rad/s]], ...]
    sin: Annotated[list[vec(2)], BeforeValidator(_pairs)] = []


class WaypointModel(Table):
    """One entry of ``reference.ee_waypoints``: a time [s] and a task pose."""

    t: Num
    z: Vec


class SamplesModel(Table):
    """``reference.ee_samples``: the inline form of ``ee_file`` (times [s], one row each)."""

    t: Annotated[Vec, Field(min_length=2)]
    z: list[Vec]


#: The keys that give the end-effector reference; exactly one is needed.
EE_KEYS = ("ee", "ee_file", "ee_samples", "ee_waypoints")


class ReferenceModel(Table):
    """``[reference]``: the task and its end-effector reference (one of the EE keys)."""

    task: Literal[TASKS] = default(Reference, "task")
    # origin "initial": c and base_attitude relative to the start pose
    origin: Literal[ORIGINS] = default(Reference, "origin")
    base_attitude: Vec | None = None  # planar angle [rad], spatial MRP; default zeros
    ee: Annotated[list[HarmonicsModel], BeforeValidator(_tables)] | None = None
    ee_file: str | None = None  # CSV "t, <one column per component>", C2 spline
    ee_samples: SamplesModel | None = None
    ee_waypoints: Annotated[list[WaypointModel], BeforeValidator(_tables)] | None = None

    @model_validator(mode="after")
    def one_reference(self):
        """Exactly one of ``ee``, ``ee_file``, ``ee_samples``, ``ee_waypoints``."""
        given = [k for k in EE_KEYS if getattr(self, k) is not None]
        if not given:
            fail(("ee",), f": missing; give one of {choices_text(EE_KEYS)}")
        if len(given) > 1:
            what = " and ".join(f"reference.{k}" for k in given)
            fail((), f": give exactly one of {choices_text(EE_KEYS)} (got {what})")
        if self.ee_waypoints is not None and len(self.ee_waypoints) < 2:
            fail(("ee_waypoints",), f": {len(self.ee_waypoints)} waypoint(s), at least 2 needed")
        if self.ee_samples is not None and len(self.ee_samples.z) != len(self.ee_samples.t):
            n_z, n_t = len(self.ee_samples.z), len(self.ee_samples.t)
            fail(("ee_samples", "z"), f": {n_z} rows, expected {n_t} (one per time in t)")
        return self

    def widths(self) -> list[tuple[tuple, int]]:
        """(key path, components) of every pose given inline (the file is read later)."""
        if self.ee is not None:
            return [(("ee",), len(self.ee))]
        if self.ee_samples is not None:
            return [(("ee_samples", "z", i), len(z)) for i, z in enumerate(self.ee_samples.z)]
        if self.ee_waypoints is not None:
            return [(("ee_waypoints", i, "z"), len(w.z)) for i, w in enumerate(self.ee_waypoints)]
        return []


class FunnelModel(Table):
    """``[controller.funnel]``: the run's performance specification (every controller is
    judged by these funnels; the lu-jia controller's transformation uses them); a number is
    used for every component."""

    rho_b0: or_list(Pos) | None = None
    rho_binf: NumOrVec | None = None  # 0 < rho_inf < rho_0: ScenarioModel's check
    beta_b: or_list(Pos) | None = None  # [1/s]
    sigma_b: or_list(Sigma) | None = None
    rho_z0: or_list(Pos) | None = None
    rho_zinf: NumOrVec | None = None
    beta_z: or_list(Pos) | None = None  # [1/s]
    sigma_z: or_list(Sigma) | None = None


class EstimatesModel(Table):
    """``[controller.estimates]``: how the initial parameter estimates are made."""

    initial: Literal[ESTIMATE_KINDS] = default(Estimates, "initial")
    spread: Fraction = default(Estimates, "spread")
    seed: int = default(Estimates, "seed")
    theta_z: Vec | None = None
    theta_d: Vec | None = None
    theta_b: Vec | None = None

    @model_validator(mode="after")
    def explicit_thetas(self):
        """``initial = "explicit"`` needs all three thetas, and only then."""
        p, thetas = "controller.estimates", ("theta_z", "theta_d", "theta_b")
        missing = [k for k in thetas if getattr(self, k) is None]
        if self.initial == "explicit" and missing:
            needs = ", ".join(f"{p}.{k}" for k in missing)
            fail((), f": initial = 'explicit' needs {needs}")
        given = [k for k in thetas if getattr(self, k) is not None]
        if self.initial != "explicit" and given:
            why = f"only used with initial = 'explicit' (initial is {self.initial!r})"
            fail((given[0],), f": {why}")
        return self


class SingularityModel(LuJiaSingularityKeys):
    """``[controller.singularity]``: ``threshold``, the run's singularity measure (the
    performance specification's: sigma_min of the inverted task Jacobian below it is near
    singular, where the built-in controllers damp their pseudo-inverse), and the lu-jia
    controller's ``max_damped_time``."""

    threshold: Pos = default(Performance, "singularity_threshold")  # [m]


class ControllerModel(LuJiaKeys):
    """``[controller]``: the controller type and its free ``params`` table, the run's
    performance specification (``funnel``, ``singularity.threshold``) and initial
    ``estimates``; the paper's keys (``scheme``, gains, ``null_space``,
    ``singularity.max_damped_time``) are the lu-jia controller's own, declared by it
    (:class:`~ffsm_pin.control.lu_jia_params.LuJiaKeys`), accepted for every type."""

    type: Annotated[str, Field(min_length=1)] = default(ControllerSpec, "type")  # registry
    params: dict[str, Any] = {}  # free table for the controller (docs/controllers.md)
    funnel: FunnelModel = FunnelModel()
    estimates: EstimatesModel = EstimatesModel()
    singularity: SingularityModel = SingularityModel()


class SimModel(Table):
    """``[sim]``: duration, step, integrator."""

    duration: Pos = default(Scenario, "duration")  # [s]
    dt: Pos = default(Scenario, "dt")  # [s]
    integrator: Literal[INTEGRATORS] = default(Scenario, "integrator")
    substeps: Annotated[int, Field(ge=1)] = default(Scenario, "substeps")  # per control step

    @model_validator(mode="after")
    def dt_within_duration(self):
        """Refuse a step longer than the run, and a run of absurdly many steps."""
        if self.dt > self.duration:
            fail(("dt",), f" = {self.dt} is longer than sim.duration = {self.duration}")
        steps = self.duration / self.dt
        if not steps <= MAX_STEPS:  # also inf (the quotient overflowed)
            fail(
                ("duration",),
                f" = {self.duration:g} s at sim.dt = {self.dt:g} s is {steps:.3g} control steps; "
                f"at most {MAX_STEPS:.0e} (shorten sim.duration or lengthen sim.dt)",
            )
        return self


class ActuatorsModel(Table):
    """``[actuators]``, :class:`~ffsm_pin.scenario.devices.ActuatorSpec` (docs/controllers.md)."""

    torque_limit: Annotated[Any, BeforeValidator(_torque_limit)] = default(
        ActuatorSpec, "torque_limit"
    )
    rate_limit: NonNegOrVec = default(ActuatorSpec, "rate_limit")  # [N m/s]
    time_constant: NonNeg = default(ActuatorSpec, "time_constant")  # [s]
    torque_noise: NonNegOrVec = default(ActuatorSpec, "torque_noise")  # [N m]
    seed: Annotated[int, Field(ge=0)] = default(ActuatorSpec, "seed")


class NoiseModel(Table):
    """``[sensors.noise]``: standard deviations, a number or one per component."""

    joints: NonNegOrVec = 0.0  # [rad]
    joint_rates: NonNegOrVec = 0.0  # [rad/s]
    base_attitude: NonNegOrVec = 0.0  # [rad] or [MRP]
    base_rate: NonNegOrVec = 0.0  # [rad/s]
    ee_pose: NonNegOrVec = 0.0  # [m, rad or MRP]
    ee_velocity: NonNegOrVec = 0.0  # [m/s, rad/s or 1/s]


class SensorsModel(Table):
    """``[sensors]``, :class:`~ffsm_pin.scenario.devices.SensorSpec` (docs/controllers.md)."""

    seed: Annotated[int, Field(ge=0)] = default(SensorSpec, "seed")
    delay: Annotated[int, Field(ge=0)] = default(SensorSpec, "delay")  # [control periods]
    noise: NoiseModel = NoiseModel()  # per key 0: no noise (SensorSpec.noise lists the others)


#: Relative slack of "inside the box" for a grasp frame (one on a face is inside), as
#: :class:`ffsm_pin.sim.target.Target`'s.
GRASP_INSIDE_TOL = 1e-9


class TargetModel(Table):
    """``[target]``, :class:`~ffsm_pin.scenario.target_spec.TargetSpec`: a box tumbling
    torque-free beside a free-flyer robot (docs/capture.md)."""

    shape: Literal[TARGET_SHAPES] = default(TargetSpec, "shape")
    urdf: str | None = None  # a one-body URDF instead of a box: its link's inertial
    size: vec(3) | None = None  # [m], edges of a box centred on the target frame; each > 0
    mass: Pos | None = None  # [kg]
    inertia: vec(6) | None = None  # ixx, iyy, izz, ixy, ixz, iyz about its CoM [kg m^2]
    position: vec(3)  # [m], of the target frame (the box's centre)
    attitude_rpy: vec(3) = default(TargetSpec, "attitude_rpy")  # [rad]
    velocity: vec(3) = default(TargetSpec, "velocity")  # [m/s], CoM, world frame
    angular_velocity: vec(3) = default(TargetSpec, "angular_velocity")  # [rad/s], body frame
    origin: Literal[TARGET_ORIGINS] = default(TargetSpec, "origin")
    grasp_xyz: vec(3) = default(TargetSpec, "grasp_xyz")  # [m], target frame
    grasp_rpy: vec(3) = default(TargetSpec, "grasp_rpy")  # [rad], target frame

    @model_validator(mode="after")
    def physical(self):
        """Refuse a box edge <= 0, an inertia no rigid body has and a grasp frame outside
        the box; a box without size or mass; box keys beside a URDF."""
        if self.urdf is not None:
            for key in ("size", "mass", "inertia"):
                if getattr(self, key) is not None:
                    fail((key,), ": not with target.urdf (the URDF's inertial is the body)")
            if "shape" in self.model_fields_set:
                fail(("shape",), ": not with target.urdf (the URDF's link is the body)")
            return self
        for key in ("size", "mass"):
            if getattr(self, key) is None:
                fail((key,), ": missing (a box needs size and mass; or give target.urdf)")
        assert self.size is not None and self.mass is not None
        for i, edge in enumerate(self.size):
            if not edge > 0:
                fail(("size", i), f" = {edge}: a box edge must be > 0 [m]")
        xx, yy, zz, xy, xz, yz = self.inertia if self.inertia is not None else self.box_inertia()
        try:
            check_inertia(
                self.mass, np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]), "the target"
            )
        except InertiaError as exc:
            why = str(exc).removeprefix("the target ")
            fail(("inertia",), f" = {list(self.inertia or [])}: {why}")
        half = 0.5 * np.array(self.size)
        if (np.abs(self.grasp_xyz) > half * (1 + GRASP_INSIDE_TOL)).any():
            fail(
                ("grasp_xyz",),
                f" = {list(self.grasp_xyz)} m is outside the target's box "
                f"(|x|, |y|, |z| <= {half.tolist()} m, target.size / 2)",
            )
        return self

    def box_inertia(self) -> list[float]:
        """The uniform box's ixx, iyy, izz, ixy, ixz, iyz about its centre [kg m^2]."""
        assert self.size is not None and self.mass is not None
        a, b, c = self.size
        m = self.mass / 12.0
        return [m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b), 0.0, 0.0, 0.0]


class CaptureModel(Table):
    """``[capture]``, :class:`~ffsm_pin.scenario.target_spec.CaptureSpec`: when the hand
    grasps the ``[target]`` (docs/capture.md)."""

    tolerance_position: Pos  # [m]
    tolerance_velocity: Pos  # [m/s]
    estimates: Literal[CAPTURE_ESTIMATES] = default(CaptureSpec, "estimates")
    hand_xyz: vec(3) = default(CaptureSpec, "hand_xyz")  # [m], end-effector frame
    hand_rpy: vec(3) = default(CaptureSpec, "hand_rpy")  # [rad], end-effector frame
    detumble_rate: Pos = default(CaptureSpec, "detumble_rate")  # [rad/s], relative to the bus


class ApproachNoiseModel(Table):
    """``[approach.noise]``: one standard deviation per key of the target's sensor."""

    position: NonNeg = 0.0  # [m]
    attitude: NonNeg = 0.0  # [rad], a rotation vector
    velocity: NonNeg = 0.0  # [m/s], CoM, world frame
    angular_velocity: NonNeg = 0.0  # [rad/s], body frame


class ApproachModel(Table):
    """``[approach]``, :class:`~ffsm_pin.scenario.target_spec.ApproachSpec`: the end-effector
    reference follows the target's grasp frame (docs/capture.md, "The approach")."""

    time: Pos  # [s], the blend from the [reference]'s to the grasp frame
    seed: Annotated[int, Field(ge=0)] = default(ApproachSpec, "seed")
    delay: Annotated[int, Field(ge=0)] = default(ApproachSpec, "delay")  # [control periods]
    noise: ApproachNoiseModel = ApproachNoiseModel()
