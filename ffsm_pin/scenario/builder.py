"""A validated scenario document -> :class:`~ffsm_pin.scenario.spec.Scenario` (the dataclasses).

Every check is the schema's (:mod:`ffsm_pin.scenario.schema`); this module only converts: TOML
lists to tuples, the spatial attitude given as rpy or a quaternion to the MRP, the reference
from data (``ee_file`` through :func:`ffsm_pin.scenario.reference_csv.read_reference_csv`,
``ee_samples``, ``ee_waypoints``), the run's performance specification and the lu-jia
controller's own parameters (k_b, k_z derived when omitted).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..control.funnel import FunnelParams
from ..control.lu_jia_params import LuJiaParams
from ..errors import ParameterError, ScenarioError
from . import schema, spec
from .devices import NOISE_KEYS, ActuatorSpec, SensorSpec
from .reference_csv import read_reference_csv
from .sections import (
    ActuatorsModel,
    ApproachModel,
    CaptureModel,
    ControllerModel,
    InitialModel,
    ReferenceModel,
    RobotModel,
    SensorsModel,
    TargetModel,
)
from .target_spec import APPROACH_NOISE_KEYS, ApproachSpec, CaptureSpec, TargetSpec
from .trajectory import ReferenceData


def build(m: schema.ScenarioModel, src: Path | None) -> spec.Scenario:
    """The dataclasses from a validated document (every check is in :mod:`.schema`).

    Parameters
    ----------
    m : schema.ScenarioModel
        The validated document.
    src : Path or None
        The file it came from.

    Returns
    -------
    spec.Scenario
        The scenario.
    """
    _, n_b, n_ee = m.sizes
    performance = _performance(m.controller, n_ee, n_b)
    return spec.Scenario(
        robot=_robot(m.robot, src),
        initial=_initial(m.initial),
        reference=_reference(m.reference, n_b, n_ee, src),
        controller=_controller(m.controller, performance, n_b, m.sim.dt),
        performance=performance,
        duration=m.sim.duration,
        dt=m.sim.dt,
        name=m.name or (src.stem if src is not None else "scenario"),
        source=src,
        description=m.description,
        integrator=m.sim.integrator,
        substeps=m.sim.substeps,
        actuators=_actuators(m.actuators),
        sensors=_sensors(m.sensors),
        target=_target(m.target, m.capture, m.approach, src),
    )


def _per_joint(x: Any) -> Any:
    """A TOML number or list as the dataclasses hold it (float or tuple of floats)."""
    return (
        tuple(float(v) for v in x) if isinstance(x, list) else x if isinstance(x, str) else float(x)
    )


def _actuators(a: ActuatorsModel) -> ActuatorSpec:
    return ActuatorSpec(
        torque_limit=_per_joint(a.torque_limit),
        rate_limit=_per_joint(a.rate_limit),
        time_constant=float(a.time_constant),
        torque_noise=_per_joint(a.torque_noise),
        seed=a.seed,
    )


def _sensors(s: SensorsModel) -> SensorSpec:
    noise = tuple(
        (key, _per_joint(getattr(s.noise, key)))
        for key in NOISE_KEYS
        if np.any(getattr(s.noise, key))  # only the quantities that have noise
    )
    return SensorSpec(seed=s.seed, delay=s.delay, noise=noise)


def _vec(x: list[float] | None) -> tuple[float, ...] | None:
    return None if x is None else _floats(x)


def _floats(x: list[float]) -> tuple[float, ...]:
    return tuple(float(v) for v in x)


def _robot(r: RobotModel, src: Path | None) -> spec.RobotSpec:
    satellite, wheels = None, None
    if r.satellite is not None:
        from ..robot import Satellite

        if r.satellite.wheels is not None:
            wheels = r.satellite.wheels.wheels()
        if r.satellite.model_fields_set != {"wheels"}:  # (only wheels: the URDF's own bus)
            satellite = Satellite(**r.satellite.model_dump(exclude={"wheels"}))
    payload = None
    if r.payload is not None:
        from ..robot import Payload

        payload = Payload(**r.payload.model_dump())
    return spec.RobotSpec(
        urdf=r.urdf,
        base=r.base,
        end_effector=r.end_effector,
        relative_to=str(src.parent.resolve()) if src is not None else None,
        locked_joints=tuple((k, float(v)) for k, v in r.locked_joints.items()),
        satellite=satellite,
        payload=payload,
        wheels=wheels,
    )


def _target(
    t: TargetModel | None, c: CaptureModel | None, a: ApproachModel | None, src: Path | None
) -> TargetSpec | None:
    if t is None:
        return None
    capture = approach = None
    if c is not None:
        capture = CaptureSpec(
            float(c.tolerance_position), float(c.tolerance_velocity), estimates=c.estimates,
            hand_xyz=_floats(c.hand_xyz), hand_rpy=_floats(c.hand_rpy),
            detumble_rate=float(c.detumble_rate),
        )  # fmt: skip
    if a is not None:
        noise = tuple(float(getattr(a.noise, key)) for key in APPROACH_NOISE_KEYS)
        approach = ApproachSpec(float(a.time), int(a.seed), int(a.delay), noise)
    vectors = ("position", "attitude_rpy", "velocity", "angular_velocity")
    return TargetSpec(
        mass=None if t.mass is None else float(t.mass),
        size=None if t.size is None else _floats(t.size),
        urdf=t.urdf,
        relative_to=str(src.parent.resolve()) if src is not None and t.urdf else None,
        shape=t.shape,
        inertia=_vec(t.inertia),
        origin=t.origin,
        **{k: _floats(getattr(t, k)) for k in (*vectors, "grasp_xyz", "grasp_rpy")},
        capture=capture,
        approach=approach,
    )


def _initial(ini: InitialModel) -> spec.InitialCondition:
    """Spatial attitude given as rpy or a unit quaternion (x, y, z, w): converted to the MRP
    on the |s| <= 1 branch and appended to base_pose = (x, y, z)."""
    base_pose = _floats(ini.base_pose)
    if ini.base_attitude_rpy is not None or ini.base_attitude_quaternion is not None:
        from ..attitude import mrp

        if ini.base_attitude_rpy is not None:
            s = mrp.from_rpy(ini.base_attitude_rpy)
        else:
            q = np.array(ini.base_attitude_quaternion)
            s = mrp.from_quaternion(q / np.linalg.norm(q))
        base_pose = base_pose + tuple(float(x) for x in s)
    joints = _floats(ini.joints)
    rates = ini.base_rate, ini.angular_momentum, ini.attitude_error
    rate, mom, error = (_vec(x) if isinstance(x, list) else x for x in rates)
    try:
        return spec.InitialCondition(
            base_pose=base_pose,
            joints=joints,
            joint_rates=_vec(ini.joint_rates) or (0.0,) * len(joints),
            com_at_origin=ini.com_at_origin,
            base_twist=_vec(ini.base_twist),
            com_velocity=_vec(ini.com_velocity),
            base_rate=rate,
            angular_momentum=mom,
            attitude_error=error,
        )
    except ParameterError as exc:
        raise ScenarioError(f"[initial] {exc}") from None


def _reference(ref: ReferenceModel, n_b: int, n_ee: int, src: Path | None) -> spec.Reference:
    base = _vec(ref.base_attitude) or (0.0,) * n_b
    data = None
    if ref.ee_file is not None:
        path = Path(ref.ee_file)
        if not path.is_absolute() and src is not None:
            path = src.parent / path
        data = read_reference_csv(path, n_ee)
    elif ref.ee_samples is not None:
        rows = tuple(tuple(z) for z in ref.ee_samples.z)
        data = _data(tuple(ref.ee_samples.t), rows, "spline")
    elif ref.ee_waypoints is not None:
        times = tuple(w.t for w in ref.ee_waypoints)
        rows = tuple(tuple(w.z) for w in ref.ee_waypoints)
        data = _data(times, rows, "waypoints")
    comps = tuple(
        spec.ComponentReference(
            c=e.c,
            cos=tuple(spec.Harmonic(amplitude=a, frequency=w) for a, w in e.cos),
            sin=tuple(spec.Harmonic(amplitude=a, frequency=w) for a, w in e.sin),
        )
        for e in ref.ee or ()
    )
    return spec.Reference(ee=comps, base_attitude=base, task=ref.task, origin=ref.origin, data=data)


def _data(times: tuple, rows: tuple, interpolation: str) -> ReferenceData:
    try:
        return ReferenceData(times, rows, interpolation)
    except ParameterError as exc:  # times not increasing; the message names the key
        raise ScenarioError(str(exc)) from None


def _performance(c: ControllerModel, n_ee: int, n_b: int) -> spec.Performance:
    """The run's performance specification: ``[controller.funnel]`` and
    ``[controller.singularity] threshold``."""
    dflt = spec.Performance()
    planar = n_b == 1  # the defaults are the paper's planar funnels: none for spatial robots
    funnel_b, funnel_z = (
        FunnelParams(**schema.funnel_arrays(c.funnel, tag, n, default if planar else None))
        for tag, n, default in (("b", n_b, dflt.funnel_b), ("z", n_ee, dflt.funnel_z))
    )
    return spec.Performance(
        funnel_b=funnel_b, funnel_z=funnel_z, singularity_threshold=c.singularity.threshold
    )


def _controller(
    c: ControllerModel, performance: spec.Performance, n_b: int, dt: float
) -> spec.ControllerSpec:
    e = c.estimates
    return spec.ControllerSpec(
        type=c.type,
        params=dict(c.params),
        estimates=spec.Estimates(
            initial=e.initial,
            spread=e.spread,
            seed=e.seed,
            **{k: _vec(getattr(e, k)) for k in ("theta_z", "theta_d", "theta_b")},
        ),
        # the lu-jia controller's keys, as it declares them (k_b, k_z derived when omitted)
        lu_jia=LuJiaParams.from_keys(c, performance.funnel_b, performance.funnel_z, dt, n_b),
    )
