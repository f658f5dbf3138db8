"""A :class:`~ffsm_pin.scenario.spec.Scenario` -> its scenario file (TOML text).

:func:`scenario_to_toml` writes every key the scenario holds (defaults included, the reference
from data as its samples, the controller type resolved), so that the file loads back into an
equal scenario: a run's saved ``scenario.toml``, a campaign's cases (their ``case_hash`` hashes
this text) and :func:`ffsm_pin.scenario.check.check_scenario` read it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..control.lu_jia_params import GAIN_KEYS
from ..control.null_space import NullSpace
from ..control.registry import resolved_type
from .devices import ActuatorSpec, SensorSpec
from .spec import Reference, Scenario
from .target_spec import APPROACH_NOISE_KEYS, DETUMBLE_RATE, TargetSpec


def scenario_to_toml(scenario: Scenario) -> str:
    """A scenario file (TOML text) that loads back into an equal scenario.

    A URDF given as a path is written as an absolute path, so the file can be moved.
    """
    r, ini, ref, c = scenario.robot, scenario.initial, scenario.reference, scenario.controller
    urdf = r.urdf
    if r.relative_to is not None and (Path(r.relative_to) / urdf).is_file():
        urdf = str((Path(r.relative_to) / urdf).resolve())
    lines = [
        f"name = {_toml(scenario.name)}",
        *([f"description = {_toml(scenario.description)}"] if scenario.description else []),
        "",
        "[robot]",
        f"urdf = {_toml(urdf)}",
        f"base = {_toml(r.base)}",
        f"end_effector = {_toml(r.end_effector)}",
    ]
    if r.locked_joints:
        inner = ", ".join(f"{_toml(k)} = {_toml(v)}" for k, v in r.locked_joints)
        lines.append(f"locked_joints = {{ {inner} }}")
    if r.satellite is not None:
        sat = r.satellite
        lines += ["", "[robot.satellite]"]
        lines += [
            f"{k} = {_toml(getattr(sat, k))}"
            for k in ("mass", "inertia", "size", "mount_xyz", "mount_rpy", "name")
        ]
    if r.wheels is not None:  # (alone: on the URDF's own bus, scenario/wheels_spec.py)
        lines += ["", "[robot.satellite.wheels]"]
        lines += [f"{k} = {_toml(v)}" for k, v in r.wheels.table().items()]
    if r.payload is not None:
        pay = r.payload
        lines += ["", "[robot.payload]"]
        lines += [f"{k} = {_toml(getattr(pay, k))}" for k in ("mass", "com", "inertia", "known")]
    lines += [
        "",
        "[initial]",
        f"base_pose = {_toml(ini.base_pose)}",
        f"com_at_origin = {_toml(ini.com_at_origin)}",
        f"joints = {_toml(ini.joints)}",
        f"joint_rates = {_toml(ini.joint_rates)}",
    ]
    for key in ("base_twist", "com_velocity", "base_rate", "angular_momentum", "attitude_error"):
        if getattr(ini, key) is not None:
            lines.append(f"{key} = {_toml(getattr(ini, key))}")
    lines += ["", "[reference]", f"task = {_toml(ref.task)}"]
    if ref.origin != "absolute":  # a run saves the resolved (absolute) reference
        lines += [f"origin = {_toml(ref.origin)}"]
    lines += [f"base_attitude = {_toml(ref.base_attitude)}", *_ee_lines(ref)]
    kind = c.type  # a registry name, or a file path resolved to an absolute one
    if isinstance(kind, str):
        kind = resolved_type(kind, scenario.source.parent if scenario.source else None)
    p, perf = c.lu_jia, scenario.performance
    lines += ["", "[controller]", f"type = {_param_toml(kind)}", f"scheme = {_toml(p.scheme)}"]
    lines += [f"{k} = {_toml(getattr(p.gains, k))}" for k in GAIN_KEYS]
    if p.saturation.mode != "ignore":  # (beyond the paper; the default writes nothing)
        lines.append(f"saturation = {_toml(p.saturation.mode)}")
        rates = (("k_chi", p.saturation.k_chi), ("k_v", p.saturation.k_v))
        lines += [f"{k} = {_toml(v)}" for k, v in rates if v is not None]
    if p.adaptation != "gradient":  # (beyond the paper; the default writes nothing)
        lines.append(f"adaptation = {_toml(p.adaptation)}")
        if p.physical_margin is not None:
            lines.append(f"physical_margin = {_toml(p.physical_margin)}")
    lines += ["", "[controller.funnel]"]
    for fun, tag in ((perf.funnel_b, "b"), (perf.funnel_z, "z")):
        lines += [
            f"rho_{tag}0 = {_toml(fun.rho0)}",
            f"rho_{tag}inf = {_toml(fun.rhoinf)}",
            f"beta_{tag} = {_toml(fun.beta)}",
            f"sigma_{tag} = {_toml(fun.sigma)}",
        ]
    e = c.estimates
    lines += [
        "",
        "[controller.estimates]",
        f"initial = {_toml(e.initial)}",
        f"spread = {_toml(e.spread)}",
        f"seed = {_int_toml(e.seed)}",
    ]
    for key in ("theta_z", "theta_d", "theta_b"):
        if getattr(e, key) is not None:
            lines.append(f"{key} = {_toml(getattr(e, key))}")
    lines += [
        "",
        "[controller.singularity]",
        f"threshold = {_toml(perf.singularity_threshold)}",
        f"max_damped_time = {_toml(p.max_damped_time)}",
        *_null_space_lines(p.null_space),
        *_params_lines(c.params),
        "",
        "[sim]",
        f"duration = {_toml(scenario.duration)}",
        f"dt = {_toml(scenario.dt)}",
        f"integrator = {_toml(scenario.integrator)}",
        f"substeps = {_int_toml(scenario.substeps)}",
        "",
    ]
    act, sen = scenario.actuators, scenario.sensors
    if act != ActuatorSpec():
        lines += ["[actuators]"]
        lines += [
            f"{k} = {_toml(getattr(act, k))}"
            for k in ("torque_limit", "rate_limit", "time_constant", "torque_noise")
        ]
        lines += [f"seed = {_int_toml(act.seed)}", ""]
    if sen != SensorSpec():
        lines += [
            "[sensors]",
            f"seed = {_int_toml(sen.seed)}",
            f"delay = {_int_toml(sen.delay)}",
            "",
        ]
        if sen.noise:
            lines += ["[sensors.noise]"]
            lines += [f"{k} = {_toml(v)}" for k, v in sen.noise]
            lines += [""]
    if scenario.target is not None:  # (a scenario without one: its text, and case_hash, as before)
        lines += _target_lines(scenario.target)
    return "\n".join(lines)


def _target_lines(target: TargetSpec) -> list[str]:
    """The [target] table (``inertia`` only when given: else the uniform box's)."""
    lines = ["[target]"]
    if target.urdf is None:
        lines.append(f"shape = {_toml(target.shape)}")
    else:  # (a path made absolute, as the robot's)
        urdf = target.urdf
        if target.relative_to is not None and (Path(target.relative_to) / urdf).is_file():
            urdf = str((Path(target.relative_to) / urdf).resolve())
        lines.append(f"urdf = {_toml(urdf)}")
    keys = ["size", "mass", "inertia", "position", "attitude_rpy", "velocity"]
    keys += ["angular_velocity", "origin", "grasp_xyz", "grasp_rpy"]
    lines += [f"{k} = {_toml(getattr(target, k))}" for k in keys if getattr(target, k) is not None]
    lines.append("")
    c = target.capture
    if c is not None:  # [capture] belongs to the target: written after it, only when given
        lines += ["[capture]", f"tolerance_position = {_toml(c.tolerance_position)}"]
        lines += [f"tolerance_velocity = {_toml(c.tolerance_velocity)}"]
        lines += [f"estimates = {_toml(c.estimates)}"]
        for key in ("hand_xyz", "hand_rpy"):  # (only when given: older files stay the same)
            if any(getattr(c, key)):
                lines.append(f"{key} = {_toml(getattr(c, key))}")
        if c.detumble_rate != DETUMBLE_RATE:  # (only when given: older files stay the same)
            lines.append(f"detumble_rate = {_toml(c.detumble_rate)}")
        lines.append("")
    a = target.approach
    if a is not None:
        lines += ["[approach]", f"time = {_toml(a.time)}", f"seed = {a.seed}"]
        lines += [f"delay = {a.delay}", "", "[approach.noise]"]
        lines += [f"{k} = {_toml(x)}" for k, x in zip(APPROACH_NOISE_KEYS, a.noise, strict=True)]
        lines.append("")
    return lines


def _ee_lines(ref: Reference) -> list[str]:
    """``ee = [...]``, or the samples of a reference from data written inline (a run's saved
    scenario holds what was flown, also when the CSV changes or origin was "initial")."""
    data = ref.data
    if data is None:
        lines = ["ee = ["]
        for comp in ref.ee:
            parts = [f"c = {_toml(comp.c)}"]
            for kind in ("cos", "sin"):
                terms = getattr(comp, kind)
                if terms:
                    parts.append(f"{kind} = {_toml([[h.amplitude, h.frequency] for h in terms])}")
            lines.append("  { " + ", ".join(parts) + " },")
        return [*lines, "]"]
    if data.interpolation == "waypoints":
        pairs = zip(data.times, data.values, strict=True)
        rows = (f"  {{ t = {_toml(t)}, z = {_toml(z)} }}," for t, z in pairs)
        return ["ee_waypoints = [", *rows, "]"]
    head = [f"# samples of {data.file}"] if data.file else []
    rows = (f"  {_toml(z)}," for z in data.values)
    return [*head, "ee_samples.t = " + _toml(data.times), "ee_samples.z = [", *rows, "]"]


def _null_space_lines(ns: NullSpace) -> list[str]:
    """The [controller.null_space] table; nothing for the paper's law (objective "none")."""
    if not ns.active:
        return []
    lines = ["", "[controller.null_space]", f"objective = {_toml(ns.objective)}"]
    lines.append(f"gain = {_toml(ns.gain)}")
    if ns.center is not None:
        lines.append(f"center = {_toml(ns.center)}")
    return lines


def _params_lines(params: Mapping[str, Any]) -> list[str]:
    """The [controller.params] table (nothing when empty)."""
    if not params:
        return []
    items = (f"{_key(k)} = {_param_toml(v)}" for k, v in params.items())
    return ["", "[controller.params]", *items]


def _key(key: str) -> str:
    return key if key.replace("_", "").replace("-", "").isalnum() else _toml(key)


def _toml(value: Any) -> str:
    if isinstance(value, np.ndarray):  # a Python-built scenario may hold arrays
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(float(value))


def _int_toml(value: Any) -> str:
    """An integer key (seeds, substeps, delay) written as an integer; any other value as its
    own TOML value, for the schema to refuse with the key's name (a scenario built in Python
    is checked through its text, :func:`check_scenario`)."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    return _param_toml(value)


def _param_toml(value: Any) -> str:
    """A free [controller.params] value: integers stay integers, tables are inline."""
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{_key(k)} = {_param_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_param_toml(v) for v in value) + "]"
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    return _toml(value)
