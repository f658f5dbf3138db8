"""Scenario files (TOML, docs/cli.md) -> :class:`~ffsm_pin.scenario.spec.Scenario`.

Validation is strict: unknown sections or keys, wrong types, wrong lengths and values out of
range are :class:`~ffsm_pin.errors.ScenarioError` whose message starts with the TOML key path
(``controller.funnel.rho_b0[0]: ...``) and, for unknown keys, suggests the closest valid key
and lists all of them. The checks are the pydantic models of
:mod:`ffsm_pin.scenario.schema`; this module reads files and builds the dataclasses.

Optional keys and their defaults (everything else in docs/cli.md is required):

* ``name`` (top level): the scenario's name, default the file's stem;
* ``[robot]``: ``urdf = "ffsm_planar4.urdf"``, ``base = "planar"``, ``end_effector = "ee"``;
* ``[initial]``: ``com_at_origin = false``, ``joint_rates`` = zeros;
* ``[reference]``: ``task = "pose"`` (or ``"position"``: the m2 position components only),
  ``base_attitude`` = zeros (1 angle planar, 3 MRP components spatial);
* ``[controller]``: ``type = "lu-jia"``, Table 2 estimates; the run's performance
  specification (:class:`~ffsm_pin.scenario.spec.Performance`): the paper's funnels (a funnel
  entry may be a single number, used for every component; spatial robots and the position task
  have no default funnels: the paper's are planar pose funnels) and the singularity threshold;
  the lu-jia controller's own keys (:mod:`ffsm_pin.control.lu_jia_params`, accepted for every
  type): ``scheme = "ppc"``, ``k_b`` and ``k_z`` derived from the funnels and dt
  (:func:`~ffsm_pin.control.gains.derived_gain`, docs/gains.md), the paper's other gains;
* ``[controller.null_space]`` (beyond the paper): ``objective = "none"`` (the paper's Eq. 36),
  ``gain = 1.0``, ``center`` = the initial joint angles,
  :class:`~ffsm_pin.control.null_space.NullSpace`;
* ``[controller.singularity]``: ``threshold`` [m] (the run's) and ``max_damped_time`` [s]
  (the lu-jia controller's), default :class:`~ffsm_pin.control.gains.SingularityPolicy`;
* ``[sim]``: ``duration = 30.0`` [s], ``dt = 0.001`` [s], ``integrator = "semi-implicit"``
  (or ``"rk4"``), ``substeps = 1`` (plant steps per control step, torque held).

Either base takes ``[robot.payload]`` (:class:`~ffsm_pin.robot.Payload`, a body held by the
end effector) and ``[initial] attitude_error`` (a base attitude error on top of ``base_pose``).

Spatial robots (``base = "free-flyer"``, docs/cli.md "Spatial robots"): ``[robot]`` also takes
``locked_joints = { name = value }`` and ``[robot.satellite]``
(:class:`~ffsm_pin.robot.Satellite`); ``[initial] base_pose`` is x, y, z and an MRP
(|s| <= 1), or x, y, z with ``base_attitude_rpy`` or ``base_attitude_quaternion`` (x, y, z,
w), converted to the MRP (written back as such by :func:`scenario_to_toml`); the velocity
keys are 3-vectors (``base_twist`` 6), all in the inertial frame.

The paper's cases and the spatial cases ship as files in ``ffsm_pin/scenario/builtin/``
(:data:`BUILTIN`).
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..control.funnel import FunnelParams
from ..control.lu_jia_params import GAIN_KEYS, LuJiaParams
from ..control.null_space import NullSpace
from ..control.registry import resolved_type
from ..errors import ParameterError, ScenarioError, choices_text, did_you_mean, not_a_file
from . import schema
from .devices import NOISE_KEYS, ActuatorSpec, SensorSpec
from .spec import (
    ComponentReference,
    ControllerSpec,
    Estimates,
    Harmonic,
    InitialCondition,
    Performance,
    Reference,
    RobotSpec,
    Scenario,
)
from .trajectory import ReferenceData

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

# Built-in scenarios: name -> file in ffsm_pin/scenario/builtin/.
BUILTIN: dict[str, str] = {
    "case1": "case1.toml",
    "case1-paper": "case1_paper.toml",
    "case2": "case2.toml",
    "case3": "case3.toml",
    "known-model": "known_model.toml",
    "planar5": "planar5.toml",
    "spatial": "spatial.toml",
    "spatial-known-model": "spatial_known_model.toml",
    "spatial-no-ppc": "spatial_no_ppc.toml",
    "spatial-no-attitude": "spatial_no_attitude.toml",
    "spatial-pose": "spatial_pose.toml",
    "spatial-realistic": "spatial_realistic.toml",
}


# ------------------------------------------------------------------------------ public API
def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file.

    Relative ``robot.urdf`` paths resolve against the file's folder.

    Raises
    ------
    ScenarioError
        Missing or unreadable file, bad TOML (with line and column), unknown or misspelt keys,
        wrong types, lengths or ranges (the message starts with the TOML key path).
    """
    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"scenario file {str(path)!r} {not_a_file(path)}")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot read scenario file {str(path)!r}: {exc}") from None
    return scenario_from_toml(text, source=path)


def scenario_from_toml(text: str, source: str | Path | None = None) -> Scenario:
    """Parse TOML text into a validated :class:`Scenario` (see :func:`scenario_from_dict`)."""
    where = str(source) if source is not None else "scenario"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{where}: invalid TOML: {exc}") from None
    return scenario_from_dict(data, source=source)


def builtin_scenario(name: str) -> Scenario:
    """One of the shipped scenarios (:data:`BUILTIN`): ``"case1"``, ``"case2"``, ..."""
    if name not in BUILTIN:
        raise ScenarioError(
            f"no built-in scenario {name!r}{did_you_mean(name, BUILTIN)}; "
            f"valid choices: {choices_text(BUILTIN)}"
        )
    return load_scenario(builtin_path(name))


def builtin_path(name: str) -> Path:
    """Path of a shipped scenario file."""
    return Path(str(resources.files("ffsm_pin.scenario.builtin").joinpath(BUILTIN[name])))


def scenario_from_dict(d: Mapping[str, Any], source: str | Path | None = None) -> Scenario:
    """Validate a parsed TOML document and build the :class:`Scenario`.

    ``source`` is the file the document came from (relative URDF paths resolve against its
    folder, and it names the scenario when there is no top-level ``name``).
    """
    if not isinstance(d, Mapping):
        raise ScenarioError(f"a scenario is a table of sections, got {type(d).__name__}")
    src = Path(source) if source is not None else None
    try:
        return _build(schema.validate(d), src)
    except ScenarioError as exc:
        if src is not None and not str(exc).startswith(str(src)):
            raise ScenarioError(f"{src}: {exc}") from None
        raise


def scenario_document(scenario: Scenario) -> dict[str, Any]:
    """The scenario as the document of its file (nested tables, TOML values): what
    :func:`scenario_to_toml` writes, read back; the form the schema validates."""
    return tomllib.loads(scenario_to_toml(scenario))


def check_scenario(scenario: Scenario) -> None:
    """Check a scenario built in Python with the scenario file's schema: one validator for
    files and Python alike (sizes for the robot's root and the task, ranges, funnels, MRP
    branches, ...). ``[controller.params]`` is the controller's own table and is not read.

    Raises
    ------
    ScenarioError
        The schema's one-line message, starting with the key that is wrong.
    """
    bare = dataclasses.replace(
        scenario, controller=dataclasses.replace(scenario.controller, params={})
    )
    schema.validate(scenario_document(bare))


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
    return "\n".join(lines)


# ------------------------------------------------------------------------------ dataclasses
def _build(m: schema.ScenarioModel, src: Path | None) -> Scenario:
    """The dataclasses from a validated document (every check is in :mod:`.schema`)."""
    _, n_b, n_ee = m.sizes
    performance = _performance(m.controller, n_ee, n_b)
    return Scenario(
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
    )


def _per_joint(x: Any) -> Any:
    """A TOML number or list as the dataclasses hold it (float or tuple of floats)."""
    return (
        tuple(float(v) for v in x) if isinstance(x, list) else x if isinstance(x, str) else float(x)
    )


def _actuators(a: schema.ActuatorsModel) -> ActuatorSpec:
    return ActuatorSpec(
        torque_limit=_per_joint(a.torque_limit),
        rate_limit=_per_joint(a.rate_limit),
        time_constant=float(a.time_constant),
        torque_noise=_per_joint(a.torque_noise),
        seed=a.seed,
    )


def _sensors(s: schema.SensorsModel) -> SensorSpec:
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


def _robot(r: schema.RobotModel, src: Path | None) -> RobotSpec:
    satellite = None
    if r.satellite is not None:
        from ..robot import Satellite

        satellite = Satellite(**r.satellite.model_dump())
    payload = None
    if r.payload is not None:
        from ..robot import Payload

        payload = Payload(**r.payload.model_dump())
    return RobotSpec(
        urdf=r.urdf,
        base=r.base,
        end_effector=r.end_effector,
        relative_to=str(src.parent.resolve()) if src is not None else None,
        locked_joints=tuple((k, float(v)) for k, v in r.locked_joints.items()),
        satellite=satellite,
        payload=payload,
    )


def _initial(ini: schema.InitialModel) -> InitialCondition:
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
        return InitialCondition(
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


def _reference(ref: schema.ReferenceModel, n_b: int, n_ee: int, src: Path | None) -> Reference:
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
        ComponentReference(
            c=e.c,
            cos=tuple(Harmonic(amplitude=a, frequency=w) for a, w in e.cos),
            sin=tuple(Harmonic(amplitude=a, frequency=w) for a, w in e.sin),
        )
        for e in ref.ee or ()
    )
    return Reference(ee=comps, base_attitude=base, task=ref.task, origin=ref.origin, data=data)


def _data(times: tuple, rows: tuple, interpolation: str) -> ReferenceData:
    try:
        return ReferenceData(times, rows, interpolation)
    except ParameterError as exc:  # times not increasing; the message names the key
        raise ScenarioError(str(exc)) from None


def read_reference_csv(path: str | Path, n_components: int) -> ReferenceData:
    """An end-effector reference from a CSV file: a header row ``t, <one name per task
    component>``, then one row per sample, times [s] increasing (docs/cli.md, ``ee_file``).

    Messages name the file and the line and say what was expected there; they never quote the
    file's content (a file that is no CSV at all, say ``/etc/passwd``, is not echoed).

    Raises
    ------
    ScenarioError
        Missing file, a folder or another file that is not regular (a FIFO, a device), an
        unreadable or non-UTF-8 file, a header whose first column is not ``t`` or with the
        wrong number of columns, a row with the wrong number of values or a non-number, times
        that do not increase.
    """
    path = Path(path)
    where = f"reference.ee_file {str(path)!r}"
    if not path.is_file():
        raise ScenarioError(f"{where} {not_a_file(path)}")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as exc:
        bad_line = path.read_bytes()[: exc.start].count(b"\n") + 1
        raise ScenarioError(
            f"{where}, line {bad_line}: not UTF-8 text; expected a CSV file"
        ) from None
    except OSError as exc:
        raise ScenarioError(f"{where}: cannot read: {exc.strerror or type(exc).__name__}") from None
    rows = [(i + 1, line) for i, line in enumerate(lines) if line.strip()]
    if not rows:
        raise ScenarioError(f"{where}: empty; expected a header row 't, ...' and samples")
    columns = n_components + 1
    head_line, head = rows[0]
    header = [h.strip() for h in head.split(",")]
    if len(header) != columns or header[0] != "t":
        found = (
            f"has {len(header)} column(s)" if len(header) != columns else "does not start with 't'"
        )
        raise ScenarioError(
            f"{where}, line {head_line}: the header row {found}; expected 't' and "
            f"{n_components} column names (one per task component), comma-separated"
        )
    times, values = [], []
    for lineno, line in rows[1:]:
        cells = line.split(",")
        if len(cells) != columns:
            raise ScenarioError(
                f"{where}, line {lineno}: {len(cells)} values, expected {columns} "
                "(t and one per task component)"
            )
        try:
            numbers = [float(c) for c in cells]
        except ValueError:
            bad = next(i for i, c in enumerate(cells) if not _is_float(c))
            raise ScenarioError(
                f"{where}, line {lineno}: not numbers (column {bad + 1}: expected a number)"
            ) from None
        times.append(numbers[0])
        values.append(tuple(numbers[1:]))
    try:
        return ReferenceData(tuple(times), tuple(values), "spline", str(path))
    except ParameterError as exc:
        raise ScenarioError(f"reference.ee_file {exc}") from None


def _is_float(text: str) -> bool:
    """Whether ``float(text)`` reads it."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _performance(c: schema.ControllerModel, n_ee: int, n_b: int) -> Performance:
    """The run's performance specification: ``[controller.funnel]`` and
    ``[controller.singularity] threshold``."""
    dflt = Performance()
    planar = n_b == 1  # the defaults are the paper's planar funnels: none for spatial robots
    funnel_b, funnel_z = (
        FunnelParams(**schema.funnel_arrays(c.funnel, tag, n, default if planar else None))
        for tag, n, default in (("b", n_b, dflt.funnel_b), ("z", n_ee, dflt.funnel_z))
    )
    return Performance(
        funnel_b=funnel_b, funnel_z=funnel_z, singularity_threshold=c.singularity.threshold
    )


def _controller(
    c: schema.ControllerModel, performance: Performance, n_b: int, dt: float
) -> ControllerSpec:
    e = c.estimates
    return ControllerSpec(
        type=c.type,
        params=dict(c.params),
        estimates=Estimates(
            initial=e.initial,
            spread=e.spread,
            seed=e.seed,
            **{k: _vec(getattr(e, k)) for k in ("theta_z", "theta_d", "theta_b")},
        ),
        # the lu-jia controller's keys, as it declares them (k_b, k_z derived when omitted)
        lu_jia=LuJiaParams.from_keys(c, performance.funnel_b, performance.funnel_z, dt, n_b),
    )


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


def load_any(spec: str | Path) -> Scenario:
    """A built-in name (``"case1"``) or a path to a scenario file."""
    if isinstance(spec, str) and spec in BUILTIN:
        return builtin_scenario(spec)
    return load_scenario(spec)


__all__ = [
    "BUILTIN",
    "builtin_path",
    "builtin_scenario",
    "check_scenario",
    "load_any",
    "load_scenario",
    "read_reference_csv",
    "scenario_from_dict",
    "scenario_document",
    "scenario_from_toml",
    "scenario_to_toml",
]
