"""Scenario files (TOML, docs/cli.md) -> :class:`~ffsm_pin.scenario.spec.Scenario`.

Validation is strict: unknown sections or keys, wrong types, wrong lengths and values out of
range are :class:`~ffsm_pin.errors.ScenarioError` whose message starts with the TOML key path
(``controller.funnel.rho_b0[0]: ...``) and, for unknown keys, suggests the closest valid key
and lists all of them. The checks are the pydantic models of
:mod:`ffsm_pin.scenario.schema`; this module reads files (and the built-in scenarios),
:mod:`ffsm_pin.scenario.builder` builds the dataclasses, :mod:`ffsm_pin.scenario.writer`
writes a scenario back as TOML.

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
w), converted to the MRP (written back as such by
:func:`~ffsm_pin.scenario.writer.scenario_to_toml`); the velocity
keys are 3-vectors (``base_twist`` 6), all in the inertial frame.

The paper's cases and the spatial cases ship as files in ``ffsm_pin/scenario/builtin/``
(:data:`BUILTIN`).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from .._docstrings import doc_entries, fill_doc
from ..errors import ScenarioError, choices_text, did_you_mean, not_a_file
from . import schema
from .builder import build
from .spec import Scenario

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    source="""
        source : str or Path or None
            The file it came from.""",
    returns_scenario="""
        Returns
        -------
        Scenario
            The scenario.""",
)

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
    "target-tumbling": "target_tumbling.toml",
    "capture": "capture.toml",
    "capture-approach": "capture_approach.toml",
    "capture-detumble": "capture_detumble.toml",
}


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


@fill_doc(_DOC)
def scenario_from_toml(text: str, source: str | Path | None = None) -> Scenario:
    """Parse TOML text into a validated :class:`Scenario` (see :func:`scenario_from_dict`).

    Parameters
    ----------
    text : str
        TOML text.
    %(source)s

    %(returns_scenario)s
    """
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


@fill_doc(_DOC)
def scenario_from_dict(d: Mapping[str, Any], source: str | Path | None = None) -> Scenario:
    """Validate a parsed TOML document and build the :class:`Scenario`.

    ``source`` is the file the document came from (relative URDF paths resolve against its
    folder, and it names the scenario when there is no top-level ``name``).

    Parameters
    ----------
    d : mapping
        The parsed document.
    %(source)s

    %(returns_scenario)s
    """
    if not isinstance(d, Mapping):
        raise ScenarioError(f"a scenario is a table of sections, got {type(d).__name__}")
    src = Path(source) if source is not None else None
    try:
        return build(schema.validate(d), src)
    except ScenarioError as exc:
        if src is not None and not str(exc).startswith(str(src)):
            raise ScenarioError(f"{src}: {exc}") from None
        raise


def load_any(spec: str | Path) -> Scenario:
    """A built-in name (``"case1"``) or a path to a scenario file."""
    if isinstance(spec, str) and spec in BUILTIN:
        return builtin_scenario(spec)
    return load_scenario(spec)


__all__ = [
    "BUILTIN",
    "builtin_path",
    "builtin_scenario",
    "load_any",
    "load_scenario",
    "scenario_from_dict",
    "scenario_from_toml",
]
