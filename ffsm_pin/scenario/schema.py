"""The scenario file (docs/cli.md) as pydantic v2 models, and one ScenarioError line per error.

The models declare the keys of every table (``extra="forbid"``), their types (strict: a string
is no number, a boolean no integer; an integer is accepted for a number), lengths, ranges and
choices. Checks that need the robot and the task (lengths of funnel arrays, base pose and
velocities; MRP on the |s| <= 1 branch; rho_inf < rho_0) are the :class:`ScenarioModel`
validator. :func:`first_error` turns a ``pydantic.ValidationError`` into the one-line
:class:`~ffsm_pin.errors.ScenarioError` message that starts with the TOML key path
(``controller.funnel.rho_b0[0]: ...``), with the valid choices or keys and a did-you-mean hint.
"""

# mypy: disable-error-code="valid-type"
# (the field types are built at run time, vec(n) and Literal over tables; pydantic checks them)

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    field_validator,
    model_validator,
)

from .._schema import Num, Pos, Vec, _is_number, _numbers, _Table, default, describe, fail
from ..control.kinematic import TASKS
from ..control.lu_jia_params import LuJiaKeys, LuJiaSingularityKeys
from ..errors import InertiaError, ScenarioError, choices_text, did_you_mean
from ..robot.geometry import check_inertia
from ..robot.payload import Payload
from ..robot.satellite import Satellite
from .devices import LIMIT_WORDS, ActuatorSpec, SensorSpec
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

#: For each supported base: (m2 end-effector position components, m3 attitude components).
TASK_SIZE = {"planar": (2, 1), "free-flyer": (3, 3)}
FUNNEL_KEYS = ("rho0", "rhoinf", "beta", "sigma")  # FunnelParams fields; TOML rho_b0, ...
MAX_STEPS = 1e12  # control steps of a run (sim.duration / sim.dt): more is no run at all


# ------------------------------------------------------------------------------ value types
def _number_or_numbers(value: Any) -> Any:
    if not _is_number(value):
        _numbers(value)
    return value


def _pairs(value: Any) -> Any:
    if not isinstance(value, list):
        fail((), f": expected a list of [amplitude, frequency] pairs, got {describe(value)}")
    for j, term in enumerate(value):
        if not (isinstance(term, list) and len(term) == 2 and all(_is_number(x) for x in term)):
            fail(
                (j,),
                f": expected [amplitude, angular_frequency] (two numbers), got {describe(term)}",
            )
    return value


def _tables(value: Any) -> Any:
    if not isinstance(value, list) or not all(isinstance(x, Mapping) for x in value):
        fail(
            (),
            ": expected a list of tables like { c = 3.9, cos = [[0.1, 0.35]] }, "
            f"got {describe(value)}",
        )
    return value


def vec(n: int) -> Any:
    """A list of exactly n finite numbers."""
    return Annotated[Vec, Field(min_length=n, max_length=n)]


def or_list(item: Any) -> Any:
    """``item`` or a list of them (funnel entries broadcast, planar/spatial rates); the union's
    tags "<...>" are left out of error paths."""
    return Annotated[
        Annotated[item, Tag("<number>")] | Annotated[list[item], Tag("<list>")],
        Discriminator(lambda v: "<list>" if isinstance(v, list) else "<number>"),
        BeforeValidator(_number_or_numbers),
    ]


def interval(text: str, inside) -> AfterValidator:
    """A range check, ``inside(x)`` true, with the message "must be in <text>"."""

    def check(x: float) -> float:
        if not inside(x):
            fail((), f" = {x}: must be in {text}")
        return x

    return AfterValidator(check)


NumOrVec = or_list(Num)
NonNeg = Annotated[float, Field(ge=0, allow_inf_nan=False)]
NonNegOrVec = or_list(NonNeg)


def _torque_limit(value: Any) -> Any:
    if isinstance(value, str):
        if value not in LIMIT_WORDS:
            fail(
                (),
                f" = {value!r} unknown{did_you_mean(value, LIMIT_WORDS)}; valid choices: "
                "'none', 'urdf', a number or one number per joint [N m]",
            )
        return value
    _number_or_numbers(value)
    for x in value if isinstance(value, list) else [value]:
        if not (x > 0 and math.isfinite(x)):
            fail((), f" = {value}: every limit must be a finite number > 0 [N m]")
    return value


Fraction = Annotated[Num, interval("[0, 1)", lambda x: 0 <= x < 1)]
Sigma = Annotated[Num, interval("(0, 1]", lambda x: 0 < x <= 1)]


# ------------------------------------------------------------------------------ sections
class SatelliteModel(_Table):
    """``[robot.satellite]``, :class:`~ffsm_pin.robot.Satellite` (defaults there)."""

    mass: Pos = default(Satellite, "mass")  # [kg]
    inertia: vec(6) = default(Satellite, "inertia")  # [kg m^2]
    size: vec(3) = default(Satellite, "size")  # [m]
    mount_xyz: vec(3) = default(Satellite, "mount_xyz")  # [m]
    mount_rpy: vec(3) = default(Satellite, "mount_rpy")  # [rad]
    name: str = default(Satellite, "name")


class PayloadModel(_Table):
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
            check_inertia(self.mass, [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], "the payload")
        except InertiaError as exc:
            fail(("inertia",), f" = {list(self.inertia)}: {str(exc).removeprefix('the payload ')}")
        return self


class RobotModel(_Table):
    """``[robot]``: the URDF, its root (planar or free-flyer), end effector, satellite."""

    urdf: str = default(RobotSpec, "urdf")
    base: Literal[tuple(TASK_SIZE)] = default(RobotSpec, "base")
    end_effector: str = default(RobotSpec, "end_effector")
    locked_joints: dict[str, Num] = {}  # [rad or m], free-flyer only
    satellite: SatelliteModel | None = None  # free-flyer only
    payload: PayloadModel | None = None  # held by the end effector

    @model_validator(mode="after")
    def spatial_only(self):
        """Refuse locked joints and a satellite body on a planar robot."""
        if (self.locked_joints or self.satellite is not None) and self.base != "free-flyer":
            fail(("locked_joints",), " and [robot.satellite] apply only to base = 'free-flyer'")
        return self


def _unit_quaternion(q: list[float]) -> list[float]:
    norm = math.sqrt(sum(x * x for x in q))
    if not abs(norm - 1.0) < 1e-6:
        fail((), f": (x, y, z, w) must have unit norm, got {norm:.6g}")
    return q


class InitialModel(_Table):
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


class HarmonicsModel(_Table):
    """One entry of ``reference.ee``: c + sum a cos(w t) + sum b sin(w t)."""

    c: Num = 0.0
    cos: Annotated[list[vec(2)], BeforeValidator(_pairs)] = []  # [[amplitude, w [rad/s]], ...]
    sin: Annotated[list[vec(2)], BeforeValidator(_pairs)] = []


class WaypointModel(_Table):
    """One entry of ``reference.ee_waypoints``: a time [s] and a task pose."""

    t: Num
    z: Vec


class SamplesModel(_Table):
    """``reference.ee_samples``: the inline form of ``ee_file`` (times [s], one row each)."""

    t: Annotated[Vec, Field(min_length=2)]
    z: list[Vec]


#: The keys that give the end-effector reference; exactly one is needed.
EE_KEYS = ("ee", "ee_file", "ee_samples", "ee_waypoints")


class ReferenceModel(_Table):
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


class FunnelModel(_Table):
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


class EstimatesModel(_Table):
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


class SimModel(_Table):
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


class ActuatorsModel(_Table):
    """``[actuators]``, :class:`~ffsm_pin.scenario.devices.ActuatorSpec` (docs/controllers.md)."""

    torque_limit: Annotated[Any, BeforeValidator(_torque_limit)] = default(
        ActuatorSpec, "torque_limit"
    )
    rate_limit: NonNegOrVec = default(ActuatorSpec, "rate_limit")  # [N m/s]
    time_constant: NonNeg = default(ActuatorSpec, "time_constant")  # [s]
    torque_noise: NonNegOrVec = default(ActuatorSpec, "torque_noise")  # [N m]
    seed: Annotated[int, Field(ge=0)] = default(ActuatorSpec, "seed")


class NoiseModel(_Table):
    """``[sensors.noise]``: standard deviations, a number or one per component."""

    joints: NonNegOrVec = 0.0  # [rad]
    joint_rates: NonNegOrVec = 0.0  # [rad/s]
    base_attitude: NonNegOrVec = 0.0  # [rad] or [MRP]
    base_rate: NonNegOrVec = 0.0  # [rad/s]
    ee_pose: NonNegOrVec = 0.0  # [m, rad or MRP]
    ee_velocity: NonNegOrVec = 0.0  # [m/s, rad/s or 1/s]


class SensorsModel(_Table):
    """``[sensors]``, :class:`~ffsm_pin.scenario.devices.SensorSpec` (docs/controllers.md)."""

    seed: Annotated[int, Field(ge=0)] = default(SensorSpec, "seed")
    delay: Annotated[int, Field(ge=0)] = default(SensorSpec, "delay")  # [control periods]
    noise: NoiseModel = NoiseModel()  # per key 0: no noise (SensorSpec.noise lists the others)


class ScenarioModel(_Table):
    """A whole scenario file; the validator checks what depends on the robot and the task."""

    name: str | None = None
    description: str = ""
    robot: RobotModel = RobotModel()
    initial: InitialModel = Field(default_factory=dict, validate_default=True)
    reference: ReferenceModel = Field(default_factory=dict, validate_default=True)
    controller: ControllerModel = ControllerModel()
    sim: SimModel = SimModel()
    actuators: ActuatorsModel = ActuatorsModel()
    sensors: SensorsModel = SensorsModel()

    @property
    def sizes(self) -> tuple[int, int, int]:
        """(m2 position components, n_b attitude components, n_ee task components)."""
        m2, n_b = TASK_SIZE[self.robot.base]
        return m2, n_b, m2 + n_b if self.reference.task == "pose" else m2

    @model_validator(mode="after")
    def robot_and_task_sizes(self):
        """Check the sizes that depend on the robot's root and the task."""
        m2, n_b, n_ee = self.sizes
        spatial = self.robot.base == "free-flyer"
        ini, ref = self.initial, self.reference
        # [initial]: base pose and velocities, planar / spatial sizes
        alt = ini.base_attitude_rpy is not None or ini.base_attitude_quaternion is not None
        if not spatial:
            for key in ("base_attitude_rpy", "base_attitude_quaternion"):
                if getattr(ini, key) is not None:
                    fail(("initial", key), ": only for base = 'free-flyer' (planar: base_pose)")
        want = 3 if alt or not spatial else 6
        if len(ini.base_pose) != want:
            what = ""
            if spatial:
                what = (
                    " (x, y, z [m] (the attitude is given by base_attitude_rpy / _quaternion))"
                    if alt
                    else " (x, y, z [m] and an MRP s1, s2, s3)"
                )
            fail(("initial", "base_pose"), f": {len(ini.base_pose)} values, expected {want}{what}")
        if spatial and not alt:
            check_mrp(ini.base_pose[3:], ("initial", "base_pose"), "[3:6]")
        for key, n in (("base_twist", 6 if spatial else 3), ("com_velocity", 3 if spatial else 2)):
            _length(getattr(ini, key), n, ("initial", key))
        for key in ("base_rate", "angular_momentum", "attitude_error"):
            value = getattr(ini, key)
            if value is not None and isinstance(value, list) != spatial:
                fail(("initial", key), f": expected {'3 numbers' if spatial else 'a number'}")
            _length(value if spatial else None, 3, ("initial", key))
        # [reference]: attitude and one entry per task component
        if ref.base_attitude is not None:
            _length(ref.base_attitude, n_b, ("reference", "base_attitude"))
            if spatial:
                check_mrp(ref.base_attitude, ("reference", "base_attitude"))
        names = ("x", "y", "z")[:m2] + (("attitude",) if n_b == 1 else ("s1", "s2", "s3"))
        for at, width in ref.widths():
            if width != n_ee:
                what = "entries" if at == ("ee",) else "values"
                fail(
                    ("reference", *at),
                    f": {width} {what}, expected {n_ee} (one per component of the "
                    f"{ref.task!r} task: {', '.join(names[:n_ee])})",
                )
        planar = n_b == 1  # the defaults are the paper's planar funnels: none for spatial robots
        dflt = Performance()
        funnel = self.controller.funnel
        funnel_arrays(funnel, "b", n_b, dflt.funnel_b if planar else None)
        funnel_arrays(funnel, "z", n_ee, dflt.funnel_z if planar else None)
        self._delay_within_run()
        return self

    def _delay_within_run(self) -> None:
        """Refuse a sensor delay as long as the run: the controller would never see anything
        but the first measurement."""
        delay, sim = self.sensors.delay, self.sim
        steps = round(sim.duration / sim.dt)
        if delay >= steps:
            fail(
                ("sensors", "delay"),
                f" = {delay} control periods ({delay * sim.dt:g} s at sim.dt = {sim.dt:g} s) is "
                f"not shorter than the run (sim.duration = {sim.duration:g} s, {steps} control "
                "periods); the controller would never see a new measurement",
            )


def _length(value: list | None, n: int, at: tuple) -> None:
    if value is not None and len(value) != n:
        fail(at, f": {len(value)} values, expected {n}")


def check_mrp(s, at: tuple, suffix: str = "") -> None:
    """An attitude MRP must be on the |s| <= 1 branch (the shadow set is the same attitude)."""
    norm = math.sqrt(sum(x * x for x in s))
    if norm > 1.0:
        fail(
            at,
            f"{suffix}: MRP {list(s)} has |s| = {norm:.4g} > 1; give the shadow MRP "
            "-s / |s|^2 of the same attitude (|s| <= 1)",
        )


def funnel_arrays(model: FunnelModel, tag: str, n: int, default) -> dict[str, tuple]:
    """FunnelParams fields of funnel ``tag`` ("b" or "z", n components): numbers broadcast,
    missing keys from ``default`` (FunnelParams of size n, else an error), rho_inf < rho_0
    (the other ranges are the FunnelModel's types)."""
    names = (f"rho_{tag}0", f"rho_{tag}inf", f"beta_{tag}", f"sigma_{tag}")
    keys = dict(zip(FUNNEL_KEYS, names, strict=True))
    what = "the base attitude" if tag == "b" else "the end-effector task"
    vals: dict[str, tuple] = {}
    for field, key in keys.items():
        at = ("controller", "funnel", key)
        raw = getattr(model, key)
        if raw is None:
            if default is None or default.size != n:  # defaults: the paper's planar funnels
                fail(at, f": missing; required for {what} ({n} components, no default)")
            vals[field] = getattr(default, field)
            continue
        v = tuple(raw) if isinstance(raw, list) else (raw,) * n
        if len(v) != n:
            fail(at, f": {len(v)} values, expected {n} (one per component of {what})")
        vals[field] = v
    k = {f: f"controller.funnel.{key}" for f, key in keys.items()}
    for i, (r0, ri) in enumerate(zip(vals["rho0"], vals["rhoinf"], strict=True)):
        if not 0 < ri < r0:
            why = f"must satisfy 0 < rho_inf < rho_0 = {r0} ({k['rho0']}[{i}])"
            fail(("controller", "funnel", keys["rhoinf"], i), f" = {ri}: {why}")
    return vals


# ------------------------------------------------------------------------------ translation
def key_path(loc: tuple) -> str:
    """``("controller", "funnel", "rho_b0", 0)`` -> ``controller.funnel.rho_b0[0]``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif not part.startswith("<"):  # union tags of NumOrVec
            out += f".{part}" if out else part
    return out


def _model_at(loc: tuple, root: type[BaseModel]) -> type[BaseModel] | None:
    """The model class of the table at ``loc`` (for the valid keys of an unknown key); a part
    ``"<tag>"`` picks the member of a tagged union."""
    model: Any = root
    annotation: Any = None
    for part in loc:
        if isinstance(part, int):
            continue
        if part.startswith("<"):
            model = model_in(annotation, part)
        else:
            field = model.model_fields.get(part) if model is not None else None
            if field is None:
                return None
            annotation = field.annotation
            model = model_in(annotation)
    return model


def model_in(annotation: Any, tag: str | None = None) -> type[BaseModel] | None:
    """The first model class in an annotation (or the union member tagged ``tag``)."""
    if tag is None and isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if tag is not None and any(
        isinstance(m, Tag) and m.tag == tag for m in getattr(annotation, "__metadata__", ())
    ):
        return model_in(annotation.__args__[0])
    for arg in getattr(annotation, "__args__", ()):
        found = model_in(arg, tag)
        if found is not None:
            return found
    return None


def _hint(name: str, choices) -> str:
    """Did-you-mean text: a valid key that the name starts with (or that starts with the name)
    first, else the closest spelling."""
    for choice in choices:
        if len(choice) >= 3 and (name.startswith(choice) or choice.startswith(name)):
            return f" (did you mean '{choice}'?)"
    return did_you_mean(name, choices)


_NUMBER = {"float_type", "float_parsing", "int_from_float"}
_WORDS = {
    "int_type": "an integer",
    "bool_type": "true or false",
    "string_type": "a string",
    "dict_type": "a table of name = value",
    "list_type": "a list",
}
_BOUND = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def message(err: Mapping[str, Any], root: type[BaseModel]) -> str:
    """One line for one pydantic error (a ``ValidationError.errors()`` entry) of a document
    validated by the model ``root``."""
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    loc = tuple(err["loc"]) + tuple(ctx.get("at", ()))
    path = key_path(loc)
    if kind == "scenario":
        return f"{path}{ctx['text']}"
    if kind == "extra_forbidden":
        where, key = loc[:-1], str(loc[-1])
        model = _model_at(where, root)
        keys = list(model.model_fields) if model is not None else []
        what = "section" if isinstance(value, Mapping) else "key"
        place = f"in [{key_path(where)}]" if where else "at the top level"
        return f"{path}: unknown {what} {place}{_hint(key, keys)}; valid keys: {choices_text(keys)}"
    if kind == "missing":
        return f"{path}: missing (required key)"
    if kind == "literal_error":
        if not isinstance(value, str):
            return f"{path}: expected a string, got {describe(value)}"
        choices = re.findall(r"'([^']*)'", ctx.get("expected", ""))
        verb = "is not supported" if path == "robot.base" else "unknown"
        return (
            f"{path} = {value!r} {verb}{did_you_mean(value, choices)}; "
            f"valid choices: {choices_text(choices)}"
        )
    if kind in _NUMBER:
        if loc and isinstance(loc[-1], int):
            at = key_path(loc[:-1])
            return f"{at}: expected a list of numbers, [{loc[-1]}] is {describe(value)}"
        return f"{path}: expected a number, got {describe(value)}"
    if kind == "finite_number":
        return f"{path} = {value}: must be finite"
    if kind in _BOUND:
        bound = next(iter(ctx.values()))
        bound = f"{bound:g}" if _is_number(bound) else bound
        return f"{path} = {value}: must be {_BOUND[kind]} {bound}"
    if kind in ("too_short", "too_long"):
        n = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        if kind == "too_short" and n == 1:
            return f"{path}: empty; give at least one value"
        return f"{path}: {ctx.get('actual_length')} values, expected {n}"
    if kind == "model_type":
        return f"{path}: expected a table [{path}], got {describe(value)}"
    if kind in _WORDS:
        return f"{path}: expected {_WORDS[kind]}, got {describe(value)}"
    return f"{path}: {err.get('msg', 'invalid value')}"  # pragma: no cover - a new pydantic type


def first_error(exc: ValidationError, root: type[BaseModel]) -> str:
    """The first error as one line (unknown keys first, like a reader scanning the file), and
    how many more there are."""
    errors = exc.errors(include_url=False)
    errors.sort(key=lambda e: e["type"] != "extra_forbidden")
    text = message(errors[0], root)
    if len(errors) > 1:
        text += f" (and {len(errors) - 1} more)"
    return text.replace("\n", " ")


def validate(d: Mapping[str, Any]) -> ScenarioModel:
    """Validate a parsed TOML document; ScenarioError (one line) if anything is wrong."""
    try:
        return ScenarioModel.model_validate(d)
    except ValidationError as exc:
        raise ScenarioError(first_error(exc, ScenarioModel)) from None
