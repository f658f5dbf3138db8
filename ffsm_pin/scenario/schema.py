"""The scenario file (docs/cli.md) as one pydantic v2 model, and one ScenarioError line per error.

:class:`ScenarioModel` is the whole file: its sections are the models of
:mod:`ffsm_pin.scenario.sections` (keys, types, lengths, ranges and choices of every table), and
its validator checks what needs the robot and the task (lengths of funnel arrays, base pose and
velocities; MRP on the |s| <= 1 branch; rho_inf < rho_0). :func:`validate` turns the first
problem into the one-line :class:`~ffsm_pin.errors.ScenarioError` message of
:func:`ffsm_pin._schema.first_error`, which starts with the TOML key path
(``controller.funnel.rho_b0[0]: ...``), with the valid choices or keys and a did-you-mean hint.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from pydantic import Field, ValidationError, model_validator

from .._schema import Table, fail, first_error
from ..errors import ScenarioError
from .sections import (
    TASK_SIZE,
    ActuatorsModel,
    ApproachModel,
    CaptureModel,
    ControllerModel,
    FunnelModel,
    InitialModel,
    ReferenceModel,
    RobotModel,
    SensorsModel,
    SimModel,
    TargetModel,
)
from .spec import Performance

FUNNEL_KEYS = ("rho0", "rhoinf", "beta", "sigma")  # FunnelParams fields; TOML rho_b0, ...


class ScenarioModel(Table):
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
    target: TargetModel | None = None  # free-flyer only
    capture: CaptureModel | None = None  # with [target] only
    approach: ApproachModel | None = None  # with [target] and task = "position" only

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
        if self.target is not None and not spatial:
            fail(("target",), ": applies only to robot.base = 'free-flyer' (capture is spatial)")
        if self.capture is not None and self.target is None:
            fail(("capture",), ": needs a [target] table (the body the hand grasps)")
        if self.approach is not None and self.target is None:
            fail(("approach",), ": needs a [target] table (the body the hand goes to)")
        if self.approach is not None and ref.task != "position":
            fail(
                ("reference", "task"),
                f" = {ref.task!r}: [approach] follows the grasp frame's position; valid "
                "choices with [approach]: 'position'",
            )
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
    """An attitude MRP must be on the |s| <= 1 branch (the shadow set is the same attitude).

    Parameters
    ----------
    s : sequence of float
        The MRP.
    at : tuple
        Where it is in the document (the keys), for the message.
    suffix : str
        Appended to the location (e.g. ``"[3:6]"``).
    """
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
    (the other ranges are the FunnelModel's types).

    Parameters
    ----------
    model : FunnelModel
        The validated funnel keys.
    tag : str
        ``"b"`` or ``"z"``.
    n : int
        Components.
    default : FunnelParams or None
        Where missing keys are taken from.

    Returns
    -------
    dict of str to tuple
        The FunnelParams fields.
    """
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


def validate(d: Mapping[str, Any]) -> ScenarioModel:
    """Validate a parsed TOML document; ScenarioError (one line) if anything is wrong."""
    try:
        return ScenarioModel.model_validate(d)
    except ValidationError as exc:
        raise ScenarioError(first_error(exc, ScenarioModel)) from None
