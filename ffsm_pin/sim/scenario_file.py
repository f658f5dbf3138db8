"""Scenario files (TOML, docs/cli.md) -> :class:`~ffsm_pin.sim.scenario.Scenario`.

Validation is strict: unknown sections or keys, wrong types, wrong lengths and values out of
range are :class:`~ffsm_pin.errors.ScenarioError` whose message starts with the TOML key path
(``controller.funnel.rho_b0[0]: ...``) and, for unknown keys, suggests the closest valid key
and lists all of them.

Optional keys and their defaults (everything else in docs/cli.md is required):

* ``name`` (top level): the scenario's name, default the file's stem;
* ``[robot]``: ``urdf = "ffsm_planar4.urdf"``, ``base = "planar"``, ``end_effector = "ee"``;
* ``[initial]``: ``com_at_origin = false``, ``joint_rates`` = zeros;
* ``[reference]``: ``task = "pose"`` (or ``"position"``: the m2 position components only),
  ``base_attitude`` = zeros (1 angle planar, 3 MRP components spatial);
* ``[controller]``: the paper's gains, funnels and Table 2 estimates (``scheme = "ppc"``);
  a funnel entry may be a single number, used for every component; spatial robots and the
  position task have no default funnels (the paper's are planar pose funnels);
* ``[controller.null_space]`` (beyond the paper): ``objective = "none"`` (the paper's Eq. 36),
  ``gain = 1.0``, ``center`` = the initial joint angles,
  :class:`~ffsm_pin.control.null_space.NullSpace`;
* ``[controller.singularity]``: ``threshold`` [m] and ``max_damped_time`` [s], default
  :class:`~ffsm_pin.control.gains.SingularityPolicy`;
* ``[sim]``: ``duration = 30.0`` [s], ``dt = 0.001`` [s], ``integrator = "semi-implicit"``
  (or ``"rk4"``), ``substeps = 1`` (plant steps per control step, torque held).

Spatial robots (``base = "free-flyer"``, docs/cli.md "Spatial robots"): ``[robot]`` also takes
``locked_joints = { name = value }`` and ``[robot.satellite]``
(:class:`~ffsm_pin.spatial.robot.Satellite`); ``[initial] base_pose`` is x, y, z and an MRP
(|s| <= 1), or x, y, z with ``base_attitude_rpy`` or ``base_attitude_quaternion`` (x, y, z,
w), converted to the MRP (written back as such by :func:`scenario_to_toml`); the velocity
keys are 3-vectors (``base_twist`` 6), all in the inertial frame.

The paper's cases and the spatial cases ship as files in ``ffsm_pin/sim/scenarios/``
(:data:`BUILTIN`).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..control.funnel import FunnelParams
from ..control.gains import Gains, SingularityPolicy
from ..control.kinematic import TASKS
from ..control.null_space import OBJECTIVES, NullSpace
from ..errors import ParameterError, ScenarioError, choices_text, did_you_mean
from .plant import INTEGRATORS
from .scenario import (
    ESTIMATE_KINDS,
    SCHEMES,
    ComponentReference,
    ControllerSpec,
    Estimates,
    Harmonic,
    InitialCondition,
    Reference,
    RobotSpec,
    Scenario,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

# Built-in scenarios: name -> file in ffsm_pin/sim/scenarios/.
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
}

# Allowed keys per table. A nested dict is a sub-table; a string is a type tag.
_NUM, _INT, _BOOL, _STR, _VEC, _NUMVEC, _TERMS = (
    "number", "integer", "boolean", "string", "list of numbers",
    "number or list of numbers", "list of [amplitude, frequency] pairs",
)  # fmt: skip
_TABLE = "table of joint_name = value"
_FUNNEL_KEYS = (
    "rho_b0",
    "rho_binf",
    "beta_b",
    "sigma_b",
    "rho_z0",
    "rho_zinf",
    "beta_z",
    "sigma_z",
)
_GAIN_KEYS = ("k_b", "k_z", "k_de", "k_d", "gamma_1", "gamma_2", "gamma_3")
SCHEMA: dict[str, Any] = {
    "name": _STR,
    "description": _STR,
    "robot": {
        "urdf": _STR,
        "base": _STR,
        "end_effector": _STR,
        "locked_joints": _TABLE,
        "satellite": {
            "mass": _NUM,
            "inertia": _VEC,
            "size": _VEC,
            "mount_xyz": _VEC,
            "mount_rpy": _VEC,
            "name": _STR,
        },
    },
    "initial": {
        "base_pose": _VEC,
        "base_attitude_rpy": _VEC,
        "base_attitude_quaternion": _VEC,
        "com_at_origin": _BOOL,
        "joints": _VEC,
        "joint_rates": _VEC,
        "base_twist": _VEC,
        "com_velocity": _VEC,
        "base_rate": _NUMVEC,
        "angular_momentum": _NUMVEC,
    },
    "reference": {"task": _STR, "base_attitude": _VEC, "ee": "list of tables"},
    "controller": {
        "scheme": _STR,
        **{k: _NUM for k in _GAIN_KEYS},
        "funnel": {k: _NUMVEC for k in _FUNNEL_KEYS},
        "estimates": {
            "initial": _STR,
            "spread": _NUM,
            "seed": _INT,
            "theta_z": _VEC,
            "theta_d": _VEC,
            "theta_b": _VEC,
        },
        "singularity": {"threshold": _NUM, "max_damped_time": _NUM},
        "null_space": {"objective": _STR, "gain": _NUM, "center": _VEC},
    },
    "sim": {"duration": _NUM, "dt": _NUM, "integrator": _STR, "substeps": _INT},
}
_EE_KEYS = {"c": _NUM, "cos": _TERMS, "sin": _TERMS}
_REQUIRED = ("initial.base_pose", "initial.joints", "reference.ee")
# For each supported base: (m2 end-effector position components, m3 attitude components).
_TASK_SIZE = {"planar": (2, 1), "free-flyer": (3, 3)}


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
        what = "is a folder, not a file" if path.is_dir() else "not found"
        raise ScenarioError(f"scenario file {str(path)!r} {what}")
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
    return Path(str(resources.files("ffsm_pin.sim.scenarios").joinpath(BUILTIN[name])))


def scenario_from_dict(d: Mapping[str, Any], source: str | Path | None = None) -> Scenario:
    """Validate a parsed TOML document and build the :class:`Scenario`.

    ``source`` is the file the document came from (relative URDF paths resolve against its
    folder, and it names the scenario when there is no top-level ``name``).
    """
    if not isinstance(d, Mapping):
        raise ScenarioError(f"a scenario is a table of sections, got {type(d).__name__}")
    src = Path(source) if source is not None else None
    try:
        _check_keys(d, SCHEMA, "")
        for key in _REQUIRED:
            section, name = key.split(".")
            if name not in d.get(section, {}):
                raise ScenarioError(f"{key}: missing (required key)")
        robot = _robot(d.get("robot", {}), src)
        m2, n_b = _TASK_SIZE[robot.base]
        initial = _initial(d["initial"], robot.base)
        reference = _reference(d["reference"], m2, n_b)
        n_ee = len(reference.ee)
        controller = _controller(d.get("controller", {}), n_ee, n_b)
        sim = d.get("sim", {})
        duration = _number(sim, "duration", "sim", default=30.0, positive=True)
        dt = _number(sim, "dt", "sim", default=1e-3, positive=True)
        if dt > duration:
            raise ScenarioError(f"sim.dt = {dt} is longer than sim.duration = {duration}")
        integrator, substeps = _integration(sim)
        name = d.get("name") or (src.stem if src is not None else "scenario")
        return Scenario(
            robot=robot,
            initial=initial,
            reference=reference,
            controller=controller,
            duration=duration,
            dt=dt,
            name=name,
            source=src,
            description=str(d.get("description", "")),
            integrator=integrator,
            substeps=substeps,
        )
    except ScenarioError as exc:
        if src is not None and not str(exc).startswith(str(src)):
            raise ScenarioError(f"{src}: {exc}") from None
        raise


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
    lines += [
        "",
        "[initial]",
        f"base_pose = {_toml(ini.base_pose)}",
        f"com_at_origin = {_toml(ini.com_at_origin)}",
        f"joints = {_toml(ini.joints)}",
        f"joint_rates = {_toml(ini.joint_rates)}",
    ]
    for key in ("base_twist", "com_velocity", "base_rate", "angular_momentum"):
        if getattr(ini, key) is not None:
            lines.append(f"{key} = {_toml(getattr(ini, key))}")
    lines += ["", "[reference]", f"task = {_toml(ref.task)}"]
    lines += [f"base_attitude = {_toml(ref.base_attitude)}", "ee = ["]
    for comp in ref.ee:
        parts = [f"c = {_toml(comp.c)}"]
        for kind in ("cos", "sin"):
            terms = getattr(comp, kind)
            if terms:
                parts.append(f"{kind} = {_toml([[h.amplitude, h.frequency] for h in terms])}")
        lines.append("  { " + ", ".join(parts) + " },")
    lines += ["]", "", "[controller]", f"scheme = {_toml(c.scheme)}"]
    lines += [f"{k} = {_toml(getattr(c.gains, k))}" for k in _GAIN_KEYS]
    lines += ["", "[controller.funnel]"]
    for fun, tag in ((c.funnel_b, "b"), (c.funnel_z, "z")):
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
        f"seed = {e.seed}",
    ]
    for key in ("theta_z", "theta_d", "theta_b"):
        if getattr(e, key) is not None:
            lines.append(f"{key} = {_toml(getattr(e, key))}")
    lines += [
        "",
        "[controller.singularity]",
        f"threshold = {_toml(c.singularity.threshold)}",
        f"max_damped_time = {_toml(c.singularity.max_damped_time)}",
        *_null_space_lines(c.null_space),
        "",
        "[sim]",
        f"duration = {_toml(scenario.duration)}",
        f"dt = {_toml(scenario.dt)}",
        f"integrator = {_toml(scenario.integrator)}",
        f"substeps = {scenario.substeps}",
        "",
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------------------ sections
def _integration(sim: Mapping) -> tuple[str, int]:
    """``[sim] integrator`` (one of plant.INTEGRATORS) and ``substeps`` (a positive integer)."""
    integrator = _string(sim, "integrator", "sim", default="semi-implicit")
    if integrator not in INTEGRATORS:
        raise ScenarioError(
            f"sim.integrator = {integrator!r} unknown{did_you_mean(integrator, INTEGRATORS)}; "
            f"valid choices: {choices_text(INTEGRATORS)}"
        )
    substeps = sim.get("substeps", 1)
    if not isinstance(substeps, int) or isinstance(substeps, bool):
        raise ScenarioError(f"sim.substeps: expected an integer, got {_describe(substeps)}")
    if substeps < 1:
        raise ScenarioError(f"sim.substeps = {substeps}: must be >= 1")
    return integrator, substeps


def _robot(sec: Mapping, src: Path | None) -> RobotSpec:
    urdf = _string(sec, "urdf", "robot", default=RobotSpec.urdf)
    base = _string(sec, "base", "robot", default=RobotSpec.base)
    if base not in _TASK_SIZE:
        raise ScenarioError(
            f"robot.base: {base!r} is not supported{did_you_mean(base, _TASK_SIZE)}; "
            f"valid choices: {choices_text(_TASK_SIZE)}"
        )
    ee = _string(sec, "end_effector", "robot", default=RobotSpec.end_effector)
    rel = str(src.parent.resolve()) if src is not None else None
    locked = sec.get("locked_joints", {})
    sat = sec.get("satellite")
    if (locked or sat is not None) and base != "free-flyer":
        raise ScenarioError(
            "robot.locked_joints and [robot.satellite] apply only to base = 'free-flyer'"
        )
    for name, value in locked.items():
        if not _is_number(value) or not math.isfinite(float(value)):
            raise ScenarioError(
                f"robot.locked_joints.{name}: expected a finite number, got {_describe(value)}"
            )
    satellite = None
    if sat is not None:
        from ..spatial.robot import Satellite

        try:
            satellite = Satellite.from_mapping(sat)
        except (ParameterError, TypeError, ValueError) as exc:
            raise ScenarioError(f"robot.{exc}") from None
    return RobotSpec(
        urdf=urdf,
        base=base,
        end_effector=ee,
        relative_to=rel,
        locked_joints=tuple((str(k), float(v)) for k, v in locked.items()),
        satellite=satellite,
    )


def _mrp(value, key: str):
    """An attitude MRP must be on the |s| <= 1 branch (the shadow set is the same attitude)."""
    norm = math.sqrt(sum(x * x for x in value))
    if norm > 1.0:
        raise ScenarioError(
            f"{key}: MRP {list(value)} has |s| = {norm:.4g} > 1; give the shadow MRP "
            "-s / |s|^2 of the same attitude (|s| <= 1)"
        )
    return value


def _base_attitude_mrp(sec: Mapping, p: str):
    """The base attitude of [initial] as an MRP from base_pose[3:], base_attitude_rpy or
    base_attitude_quaternion (exactly one), converted to an MRP on the |s| <= 1 branch."""
    from ..spatial import mrp

    rpy = _vector(sec, "base_attitude_rpy", p, length=3, default=None)
    quat = _vector(sec, "base_attitude_quaternion", p, length=4, default=None)
    if rpy is not None and quat is not None:
        raise ScenarioError(
            f"{p}.base_attitude_rpy and {p}.base_attitude_quaternion: give one of them"
        )
    if rpy is not None:
        return tuple(float(x) for x in mrp.from_rpy(rpy))
    if quat is not None:
        norm = math.sqrt(sum(x * x for x in quat))
        if not abs(norm - 1.0) < 1e-6:
            raise ScenarioError(
                f"{p}.base_attitude_quaternion: (x, y, z, w) must have unit norm, got {norm:.6g}"
            )
        return tuple(float(x) for x in mrp.from_quaternion(np.array(quat) / norm))
    return None


def _initial(sec: Mapping, base: str = "planar") -> InitialCondition:
    p = "initial"
    spatial = base == "free-flyer"
    att = _base_attitude_mrp(sec, p) if spatial else None
    if not spatial:
        for key in ("base_attitude_rpy", "base_attitude_quaternion"):
            if key in sec:
                raise ScenarioError(f"{p}.{key}: only for base = 'free-flyer' (planar: base_pose)")
    if spatial:
        base_pose = _vector(sec, "base_pose", p)
        want = 3 if att is not None else 6
        if len(base_pose) != want:
            what = (
                "x, y, z [m] (the attitude is given by base_attitude_rpy / _quaternion)"
                if att is not None
                else "x, y, z [m] and an MRP s1, s2, s3"
            )
            raise ScenarioError(f"{p}.base_pose: {len(base_pose)} values, expected {want} ({what})")
        if att is not None:
            base_pose = tuple(base_pose) + att
        _mrp(base_pose[3:], f"{p}.base_pose[3:6]")
    else:
        base_pose = _vector(sec, "base_pose", p, length=3)
    joints = _vector(sec, "joints", p)
    if not joints:
        raise ScenarioError("initial.joints: empty; give one angle [rad] per joint")
    rates = _vector(sec, "joint_rates", p, default=(0.0,) * len(joints))
    if len(rates) != len(joints):
        raise ScenarioError(
            f"initial.joint_rates: {len(rates)} values, but initial.joints has {len(joints)}"
        )
    twist = _vector(sec, "base_twist", p, length=6 if spatial else 3, default=None)
    com_v = _vector(sec, "com_velocity", p, length=3 if spatial else 2, default=None)
    if spatial:
        rate = _vector(sec, "base_rate", p, length=3, default=None)
        mom = _vector(sec, "angular_momentum", p, length=3, default=None)
    else:
        rate = _number(sec, "base_rate", p, default=None)
        mom = _number(sec, "angular_momentum", p, default=None)
    com = _bool(sec, "com_at_origin", p, default=False)
    try:
        return InitialCondition(
            base_pose=base_pose,
            joints=joints,
            joint_rates=rates,
            com_at_origin=com,
            base_twist=twist,
            com_velocity=com_v,
            base_rate=rate,
            angular_momentum=mom,
        )
    except ParameterError as exc:
        raise ScenarioError(f"[initial] {exc}") from None


def _reference(sec: Mapping, m2: int, n_b: int) -> Reference:
    task = _string(sec, "task", "reference", default="pose")
    if task not in TASKS:
        raise ScenarioError(
            f"reference.task: {task!r} unknown{did_you_mean(task, TASKS)}; "
            f"valid choices: {choices_text(TASKS)}"
        )
    n_ee = m2 + n_b if task == "pose" else m2
    names = (("x", "y", "z")[:m2] + (("attitude",) if n_b == 1 else ("s1", "s2", "s3")))[:n_ee]
    base = _vector(sec, "base_attitude", "reference", length=n_b, default=(0.0,) * n_b)
    if n_b == 3:
        _mrp(base, "reference.base_attitude")
    ee = sec["ee"]
    if not isinstance(ee, list) or not all(isinstance(x, Mapping) for x in ee):
        raise ScenarioError(
            "reference.ee: expected a list of tables like { c = 3.9, cos = [[0.1, 0.35]] }, "
            f"got {_describe(ee)}"
        )
    if len(ee) != n_ee:
        raise ScenarioError(
            f"reference.ee: {len(ee)} entries, expected {n_ee} (one per component of the "
            f"{task!r} task: {', '.join(names)})"
        )
    comps = []
    for i, entry in enumerate(ee):
        where = f"reference.ee[{i}]"
        _check_keys(entry, _EE_KEYS, where)
        c = _number(entry, "c", where, default=0.0)
        terms = {kind: _terms(entry, kind, where) for kind in ("cos", "sin")}
        comps.append(ComponentReference(c=c, **terms))
    return Reference(ee=tuple(comps), base_attitude=base, task=task)


def _terms(entry: Mapping, kind: str, where: str) -> tuple[Harmonic, ...]:
    value = entry.get(kind, [])
    key = f"{where}.{kind}"
    if not isinstance(value, list):
        raise ScenarioError(f"{key}: expected {_TERMS}, got {_describe(value)}")
    out = []
    for j, term in enumerate(value):
        if not (isinstance(term, list) and len(term) == 2 and all(_is_number(x) for x in term)):
            raise ScenarioError(
                f"{key}[{j}]: expected [amplitude, angular_frequency] (two numbers), "
                f"got {_describe(term)}"
            )
        a, w = (float(x) for x in term)
        if not (math.isfinite(a) and math.isfinite(w)):
            raise ScenarioError(f"{key}[{j}]: must be finite, got {term}")
        out.append(Harmonic(amplitude=a, frequency=w))
    return tuple(out)


def _controller(sec: Mapping, n_ee: int, n_b: int) -> ControllerSpec:
    p = "controller"
    scheme = _string(sec, "scheme", p, default="ppc")
    if scheme not in SCHEMES:
        raise ScenarioError(
            f"controller.scheme: {scheme!r} unknown{did_you_mean(scheme, SCHEMES)}; "
            f"valid choices: {choices_text(SCHEMES)}"
        )
    defaults = Gains()
    gains = {k: _number(sec, k, p, default=getattr(defaults, k), positive=True) for k in _GAIN_KEYS}
    fsec = sec.get("funnel", {})
    dflt = ControllerSpec()
    planar = n_b == 1  # the defaults are the paper's planar funnels: none for spatial robots
    funnel_b = _funnel(fsec, "b", n_b, dflt.funnel_b if planar else None)
    funnel_z = _funnel(fsec, "z", n_ee, dflt.funnel_z if planar else None)
    estimates = _estimates(sec.get("estimates", {}))
    ssec = sec.get("singularity", {})
    sp = SingularityPolicy()
    sing = {
        k: _number(ssec, k, "controller.singularity", default=getattr(sp, k), positive=True)
        for k in ("threshold", "max_damped_time")
    }
    null_space = _null_space(sec.get("null_space", {}))
    try:
        return ControllerSpec(
            scheme=scheme,
            gains=Gains(**gains),
            funnel_b=funnel_b,
            funnel_z=funnel_z,
            estimates=estimates,
            singularity=SingularityPolicy(**sing),
            null_space=null_space,
        )
    except ParameterError as exc:  # pragma: no cover - everything is pre-checked above
        raise ScenarioError(f"[controller] {exc}") from None


def _null_space(sec: Mapping) -> NullSpace:
    p = "controller.null_space"
    objective = _string(sec, "objective", p, default=NullSpace.objective)
    if objective not in OBJECTIVES:
        raise ScenarioError(
            f"{p}.objective: {objective!r} unknown{did_you_mean(objective, OBJECTIVES)}; "
            f"valid choices: {choices_text(OBJECTIVES)}"
        )
    gain = _number(sec, "gain", p, default=NullSpace.gain)
    if gain < 0:
        raise ScenarioError(f"{p}.gain = {gain}: must be >= 0")
    center = _vector(sec, "center", p, default=None)
    if center is not None and objective != "joint-centering":
        raise ScenarioError(
            f"{p}.center: only used with objective = 'joint-centering' (objective is {objective!r})"
        )
    return NullSpace(objective=objective, gain=gain, center=center)


def _null_space_lines(ns: NullSpace) -> list[str]:
    """The [controller.null_space] table; nothing for the paper's law (objective "none")."""
    if not ns.active:
        return []
    lines = ["", "[controller.null_space]", f"objective = {_toml(ns.objective)}"]
    lines.append(f"gain = {_toml(ns.gain)}")
    if ns.center is not None:
        lines.append(f"center = {_toml(ns.center)}")
    return lines


def _funnel(sec: Mapping, tag: str, n: int, default: FunnelParams | None) -> FunnelParams:
    keys = {
        "rho0": f"rho_{tag}0",
        "rhoinf": f"rho_{tag}inf",
        "beta": f"beta_{tag}",
        "sigma": f"sigma_{tag}",
    }
    what = "the base attitude" if tag == "b" else "the end-effector task"
    vals = {}
    for field_name, key in keys.items():
        full = f"controller.funnel.{key}"
        if key not in sec:
            if default is None or default.size != n:  # defaults: the paper's planar funnels
                raise ScenarioError(
                    f"{full}: missing; required for {what} ({n} components, no default)"
                )
            vals[field_name] = getattr(default, field_name)
            continue
        raw = sec[key]
        if _is_number(raw):
            raw = [raw] * n
        v = _vector({key: raw}, key, "controller.funnel", length=None)
        if len(v) != n:
            raise ScenarioError(
                f"{full}: {len(v)} values, expected {n} (one per component of {what})"
            )
        vals[field_name] = v
    for i in range(n):
        r0, ri = vals["rho0"][i], vals["rhoinf"][i]
        b, s = vals["beta"][i], vals["sigma"][i]
        k = {f: f"controller.funnel.{keys[f]}[{i}]" for f in keys}
        if not r0 > 0:
            raise ScenarioError(f"{k['rho0']} = {r0}: must be > 0")
        if not 0 < ri < r0:
            raise ScenarioError(
                f"{k['rhoinf']} = {ri}: must satisfy 0 < rho_inf < rho_0 = {r0} ({k['rho0']})"
            )
        if not b > 0:
            raise ScenarioError(f"{k['beta']} = {b}: must be > 0 [1/s]")
        if not 0 < s <= 1:
            raise ScenarioError(f"{k['sigma']} = {s}: must be in (0, 1]")
    try:
        return FunnelParams(**vals)
    except ParameterError as exc:  # pragma: no cover - pre-checked above
        raise ScenarioError(f"controller.funnel ({tag}): {exc}") from None


def _estimates(sec: Mapping) -> Estimates:
    p = "controller.estimates"
    kind = _string(sec, "initial", p, default="paper")
    if kind not in ESTIMATE_KINDS:
        raise ScenarioError(
            f"{p}.initial: {kind!r} unknown{did_you_mean(kind, ESTIMATE_KINDS)}; "
            f"valid choices: {choices_text(ESTIMATE_KINDS)}"
        )
    spread = _number(sec, "spread", p, default=0.3)
    if not 0 <= spread < 1:
        raise ScenarioError(f"{p}.spread = {spread}: must be in [0, 1)")
    seed = sec.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise ScenarioError(f"{p}.seed: expected an integer, got {_describe(seed)}")
    thetas = {k: _vector(sec, k, p, default=None) for k in ("theta_z", "theta_d", "theta_b")}
    given = [k for k, v in thetas.items() if v is not None]
    if kind == "explicit":
        missing = [k for k in thetas if thetas[k] is None]
        if missing:
            raise ScenarioError(
                f"{p}: initial = 'explicit' needs {', '.join(f'{p}.{k}' for k in missing)}"
            )
    elif given:
        raise ScenarioError(
            f"{p}.{given[0]}: only used with initial = 'explicit' (initial is {kind!r})"
        )
    return Estimates(initial=kind, spread=spread, seed=seed, **thetas)


# ------------------------------------------------------------------------------ helpers
def _check_keys(table: Mapping, schema: Mapping, where: str) -> None:
    """Unknown keys -> ScenarioError with a did-you-mean hint; sub-tables must be tables."""
    for key, value in table.items():
        full = f"{where}.{key}" if where else key
        if key not in schema:
            kind = "section" if isinstance(value, Mapping) else "key"
            place = f"in [{where}]" if where else "at the top level"
            raise ScenarioError(
                f"{full}: unknown {kind} {place}{_hint(key, schema)}; "
                f"valid keys: {choices_text(schema)}"
            )
        sub = schema[key]
        if isinstance(sub, Mapping):
            if not isinstance(value, Mapping):
                raise ScenarioError(f"{full}: expected a table [{full}], got {_describe(value)}")
            _check_keys(value, sub, full)
        elif sub == _TABLE:
            if not isinstance(value, Mapping):
                raise ScenarioError(f"{full}: expected a {sub}, got {_describe(value)}")
        elif isinstance(value, Mapping):
            raise ScenarioError(f"{full}: expected a {sub}, got a table")


def _hint(name: str, choices) -> str:
    """Did-you-mean text: a valid key that the name starts with (or that starts with the name)
    first, else the closest spelling."""
    for choice in choices:
        if len(choice) >= 3 and (name.startswith(choice) or choice.startswith(name)):
            return f" (did you mean '{choice}'?)"
    return did_you_mean(name, choices)


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _describe(x: Any) -> str:
    names = {bool: "boolean", int: "integer", float: "number", str: "string", list: "list"}
    kind = names.get(type(x), "table" if isinstance(x, Mapping) else type(x).__name__)
    text = repr(x)
    return f"{text[:60] + '...' if len(text) > 60 else text} ({kind})"


_MISSING = object()


def _number(sec: Mapping, key: str, where: str, *, default: Any = _MISSING, positive=False):
    full = f"{where}.{key}"
    if key not in sec:
        if default is _MISSING:
            raise ScenarioError(f"{full}: missing (required key)")
        return default
    value = sec[key]
    if not _is_number(value):
        raise ScenarioError(f"{full}: expected a number, got {_describe(value)}")
    value = float(value)
    if not math.isfinite(value):
        raise ScenarioError(f"{full} = {value}: must be finite")
    if positive and not value > 0:
        raise ScenarioError(f"{full} = {value}: must be > 0")
    return value


def _string(sec: Mapping, key: str, where: str, *, default: str) -> str:
    value = sec.get(key, default)
    if not isinstance(value, str):
        raise ScenarioError(f"{where}.{key}: expected a string, got {_describe(value)}")
    return value


def _bool(sec: Mapping, key: str, where: str, *, default: bool) -> bool:
    value = sec.get(key, default)
    if not isinstance(value, bool):
        raise ScenarioError(f"{where}.{key}: expected true or false, got {_describe(value)}")
    return value


def _vector(
    sec: Mapping, key: str, where: str, *, length: int | None = None, default: Any = _MISSING
):
    full = f"{where}.{key}"
    if key not in sec:
        if default is _MISSING:
            raise ScenarioError(f"{full}: missing (required key)")
        return default
    value = sec[key]
    if not isinstance(value, list) or not all(_is_number(x) for x in value):
        raise ScenarioError(f"{full}: expected a list of numbers, got {_describe(value)}")
    out = tuple(float(x) for x in value)
    if not all(math.isfinite(x) for x in out):
        raise ScenarioError(f"{full}: values must be finite, got {list(out)}")
    if length is not None and len(out) != length:
        raise ScenarioError(f"{full}: {len(out)} values, expected {length}")
    return out


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(float(value))


def load_any(spec: str | Path) -> Scenario:
    """A built-in name (``"case1"``) or a path to a scenario file."""
    if isinstance(spec, str) and spec in BUILTIN:
        return builtin_scenario(spec)
    return load_scenario(spec)


__all__ = [
    "BUILTIN",
    "SCHEMA",
    "builtin_path",
    "builtin_scenario",
    "load_any",
    "load_scenario",
    "scenario_from_dict",
    "scenario_from_toml",
    "scenario_to_toml",
]
