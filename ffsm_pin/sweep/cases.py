"""A :class:`~ffsm_pin.sweep.campaign.Campaign` -> its cases (:func:`expand`).

* with several scenarios, each gets the cases below in turn (its own nominal case first), and
  the column ``scenario`` says which; the grid's seeds are the same for every scenario;
* case 0 is the nominal scenario: the scenario file as it is, with only the run length and
  step applied (``duration``/``dt``, or ``sim.duration``/``sim.dt`` of ``[campaign.set]``;
  no other set, varied or sampled key, its own estimates seed);
* cases 1.. are the Cartesian product of the ``[[vary]]`` axes (in file order, the last axis
  fastest) times ``repeat`` draws, repeats innermost. Each case sets
  ``controller.estimates.seed`` and draws its sampled keys from its own random stream
  (:mod:`ffsm_pin.sweep.seeds`); a case whose ``controller.type`` (varied, set, or its
  scenario's, as written) has a ``set_for_controller`` table gets its keys too. A table for a
  type that none of these cases has is bad input.

Every case's scenario is the scenario file's TOML document with the keys replaced, validated by
:func:`ffsm_pin.scenario.file.scenario_from_dict` exactly like a file; the case records the
value each key has in the resolved scenario (read back from its TOML form). Its ``case_hash``
hashes that scenario's TOML text and the package version.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import sys
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from .._schema import _is_number, describe, model_in
from ..control.registry import DEFAULT_TYPE
from ..errors import FfsmError, choices_text, did_you_mean
from ..scenario.file import scenario_from_dict
from ..scenario.schema import ScenarioModel
from ..scenario.spec import Scenario
from ..scenario.writer import scenario_to_toml
from .campaign import SCENARIO_COLUMN, TYPE_KEY, Campaign, CampaignError, Disperse, _lookup
from .campaign_schema import SEED_KEY
from .seeds import case_stream, estimates_seed

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["Case", "expand", "keeps_draws"]

#: The prefix of the keys that say what the controller knows to begin with: they define the
#: draw (its spread, its seed), so they change the draws; every other ``controller.`` key is
#: a treatment compared on common draws.
DRAW_KEYS = "controller.estimates."


def keeps_draws(key: str) -> bool:
    """Whether a grid axis leaves a case's random draws (estimates, samples, dispersions) as
    they are: the scenario and every choice of the controller (``controller.type``, its options
    and gains: any ``controller.`` key but ``controller.estimates.*``), so that the cases of
    every scenario and every controller variant at one grid point and repeat draw alike
    (common random numbers, the report's paired comparison).

    Parameters
    ----------
    key : str
        The axis: a dotted scenario key or the column ``scenario``.

    Returns
    -------
    bool
        True for the scenario and the controller's treatments.
    """
    if key == SCENARIO_COLUMN:
        return True
    return key.startswith("controller.") and not key.startswith(DRAW_KEYS)


@dataclass(frozen=True)
class Case:
    """One run of a campaign.

    Attributes
    ----------
    index : int
        Position in the campaign (0 = nominal).
    nominal : bool
        The nominal case (the scenario file as it is, with only the run length and step
        applied).
    point_index : int or None
        Grid point number (None for the nominal case).
    repeat : int or None
        Repeat index within the grid point (None for the nominal case).
    point : mapping
        Grid point {dotted key: value as written in the campaign}.
    values : dict
        {column: value the resolved scenario uses}.
    estimates_seed : int
        The case's ``controller.estimates.seed``.
    scenario_toml : str
        The resolved scenario (loads with ``scenario_from_toml``).
    case_hash : str
        Hash of the resolved scenario's TOML text and the package version.
    scenario : Scenario
        The resolved scenario.
    """

    index: int  # position in the campaign (0 = nominal)
    nominal: bool
    point_index: int | None  # grid point number (None for the nominal case)
    repeat: int | None  # repeat index within the grid point (None for the nominal case)
    point: Mapping[str, Any]  # grid point {dotted key: value as written in the campaign}
    values: dict[str, Any]  # {column: value the resolved scenario uses}
    estimates_seed: int
    scenario_toml: str  # the resolved scenario (loads with scenario_from_toml)
    case_hash: str
    scenario: Scenario = field(repr=False, compare=False)

    def label(self) -> str:
        """The case's grid point in words, as the report shows it."""
        if self.nominal:
            return "nominal" + "".join(f" {v}" for v in self.point.values())
        return ", ".join(f"{k} = {_fmt(v)}" for k, v in self.point.items()) or "all"


def expand(campaign: Campaign) -> list[Case]:
    """Every case of the campaign, validated (see the module docstring).

    Raises
    ------
    CampaignError
        A scenario file that does not load, or a value the scenario validation refuses (the
        message names the campaign file, the key and the value).
    """
    several = len(campaign.scenarios) > 1
    common = {}  # run length and step, also for the nominal case (comparable rows)
    for opt, full in (("duration", "sim.duration"), ("dt", "sim.dt")):
        if getattr(campaign, opt) is not None:
            common[full] = getattr(campaign, opt)
        elif full in campaign.set:
            common[full] = campaign.set[full]
    cases: list[Case] = []
    points = list(itertools.product(*(v.values for v in campaign.vary)))
    scenarios = zip(campaign.scenarios, campaign.scenario_paths, strict=True)
    for which, (name, path) in enumerate(scenarios):
        try:
            base = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise CampaignError(f"{campaign.source}: scenario {str(path)!r}: {exc}") from None
        own = campaign.set_for.get(name, {})
        tag = {SCENARIO_COLUMN: name} if several else {}
        index = len(cases)
        label = f"nominal scenario {name}" if several else "nominal scenario"
        cases.append(
            _case(campaign, base, path, index, None, None, tag, common, _seed_of(base), label)
        )
        sizes = _disperse_sizes(campaign, base, path, cases[-1].scenario_toml)
        for p, values in enumerate(points):
            point = {**tag, **{v.key: x for v, x in zip(campaign.vary, values, strict=True)}}
            # every scenario and every controller variant draws the same seeds (common random
            # numbers: the paired comparison of the report compares them on the same draws; a
            # campaign over one scenario and one controller draws what it drew before)
            grid = {k: v for k, v in point.items() if k != SCENARIO_COLUMN}
            draws = {k: v for k, v in grid.items() if not keeps_draws(k)}
            for r in range(campaign.repeat):
                seed = estimates_seed(campaign.seed, draws, r)
                keys = {**common, **campaign.set, **own, **grid, SEED_KEY: seed}
                for s in campaign.sample:
                    stream = case_stream(campaign.seed, draws, r, "sample:" + s.key)
                    keys[s.key] = s.draw(np.random.default_rng(stream))
                drawn = {}
                for d in campaign.disperse:  # each key its own stream: others' draws unchanged
                    stream = case_stream(campaign.seed, draws, r, "disperse:" + d.key)
                    drawn[d.key] = d.draw(np.random.default_rng(stream), sizes[d.key])
                keys.update(drawn)
                # the keys of this case's controller type (disjoint from the others: schema)
                kind = keys.get(TYPE_KEY, _lookup(base, TYPE_KEY, DEFAULT_TYPE))
                if isinstance(kind, str):
                    keys.update(campaign.set_for_controller.get(kind, {}))
                index = len(cases)
                point_index = p + len(points) * which
                case = _case(campaign, base, path, index, point_index, r, point, keys, seed)
                _check_arrived(case, drawn, campaign.source)
                cases.append(case)
    for col in campaign.columns:  # one type per column: lists if any case resolves to a list
        if any(isinstance(c.values[col], list) for c in cases):
            for c in cases:
                c.values[col] = _lookup(tomllib.loads(c.scenario_toml), col, c.values[col])
    hashes: dict[str, int] = {}
    for case in cases:
        if case.case_hash in hashes:
            raise CampaignError(
                f"{campaign.source}: cases {hashes[case.case_hash]} and {case.index} resolve to "
                "the same scenario (a varied value that the scenario does not use?)"
            )
        hashes[case.case_hash] = case.index
    return cases


def _disperse_sizes(
    campaign: Campaign, doc: Mapping, path: Path, nominal_toml: str
) -> dict[str, int | None]:
    """For each ``[campaign.disperse]`` key: None (a number is drawn) or the number of values
    (element-wise); CampaignError (one line) for a key that is no scenario key or not numeric.

    ``doc`` is the scenario file's document, ``nominal_toml`` its resolved nominal case. A key
    whose value in the scenario (its file, or the default the resolved scenario writes) is a
    list of numbers is drawn element-wise with that length (a list bound must have it);
    a number, or a key the file leaves out whose value may be a number, is drawn as a number
    (as a list where a bound is a list). ``angle`` draws a 3-vector on a free-flyer robot and
    an angle on a planar one unless the value is already a list or a number.
    """
    out: dict[str, int | None] = {}
    if not campaign.disperse:
        return out
    where = f"{campaign.source}: campaign.disperse"
    resolved = tomllib.loads(nominal_toml)  # the scenario file's values and defaults
    for d in campaign.disperse:
        _schema_key(d.key, where)
        value = _lookup(resolved, d.key, _lookup(doc, d.key))
        size = d.size()
        if (
            isinstance(value, bool)
            or isinstance(value, (str, Mapping))
            and not _takes_number(doc, d, path)
        ):
            raise CampaignError(
                f"{where}: {d.key} is not numeric (its value is {describe(value)}); "
                "[campaign.disperse] draws numbers"
            )
        if isinstance(value, list):
            if not all(_is_number(x) for x in value):
                raise CampaignError(
                    f"{where}: {d.key} is not numeric (its value is {describe(value)}); "
                    "[campaign.disperse] draws numbers"
                )
            if size is not None and size != len(value):
                raise CampaignError(
                    f"{where}: {d.key} has {len(value)} values in scenario {str(path)!r}, the "
                    f"bounds have {size}"
                )
            size = len(value)
        elif d.distribution == "angle" and value is None:
            base = _lookup(resolved, "robot.base", "planar")
            size = 3 if base == "free-flyer" else None
        if d.distribution == "angle" and size not in (None, 3):
            raise CampaignError(
                f"{where}: {d.key} = {{ angle = ... }} draws a rotation (3 numbers, or a planar "
                f"angle); the key has {size} values"
            )
        out[d.key] = size
    return out


def _takes_number(doc: Mapping, d: Disperse, path: Path) -> bool:
    """Whether the scenario validation accepts a number drawn for ``d`` (a key whose value is
    a word, like ``actuators.torque_limit = "none"``)."""
    trial = copy.deepcopy(dict(doc))
    first = d.params[0]
    _assign(trial, d.key, float(first[0] if isinstance(first, list) else first), "")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scenario_from_dict(trial, source=path)
    except FfsmError:
        return False
    return True


def _schema_key(key: str, where: str) -> None:
    """CampaignError unless ``key`` is a key of the scenario file (docs/cli.md); the free
    tables (``controller.params``, ``robot.locked_joints``) take any name."""
    model: Any = ScenarioModel
    parts = key.split(".")
    for i, part in enumerate(parts):
        fields = model.model_fields
        if part not in fields:
            at = ".".join(parts[:i]) or "the top level"
            raise CampaignError(
                f"{where}: {key} is not a scenario key ({part!r} unknown in {at}"
                f"{did_you_mean(part, fields)}; valid keys: {choices_text(fields)})"
            )
        annotation = fields[part].annotation
        inner = model_in(annotation)
        if inner is None:
            if i < len(parts) - 1 and not _is_free_table(annotation):
                raise CampaignError(f"{where}: {key}: {'.'.join(parts[: i + 1])} is a value")
            return
        model = inner
    raise CampaignError(f"{where}: {key} is a table, not a value")


def _is_free_table(annotation: Any) -> bool:
    """A ``dict[str, ...]`` table whose keys are free (parameters, locked joints)."""
    return getattr(annotation, "__origin__", None) is dict or "dict[" in str(annotation)


def _check_arrived(case: Case, drawn: Mapping[str, Any], source: str) -> None:
    """Every dispersed value must be in the case's resolved scenario, as drawn (a value that
    the scenario does not use, or holds in another form, is refused: no silent dispersion)."""
    resolved = tomllib.loads(case.scenario_toml)
    for key, value in drawn.items():
        got = _lookup(resolved, key)
        want = (
            value
            if isinstance(value, list)
            else [value] * (len(got) if isinstance(got, list) else 1)
        )
        have = got if isinstance(got, list) else [got]
        ok = len(have) == len(want) and all(
            _is_number(h) and float(h) == float(w) for h, w in zip(have, want, strict=True)
        )
        if not ok:
            raise CampaignError(
                f"{source}: case {case.index}: campaign.disperse {key} drew {value}, but the "
                f"case's resolved scenario holds {got!r}; this key cannot be dispersed"
            )


def _seed_of(doc: Mapping) -> int:
    seed = doc.get("controller", {}).get("estimates", {}).get("seed", 0)
    return seed if isinstance(seed, int) else 0


def _case(campaign, base, path, index, p, r, point, keys, seed, label=None) -> Case:
    doc = copy.deepcopy(base)
    for key, value in keys.items():
        _assign(doc, key, value, campaign.source)
    what = label or ", ".join(
        f"{k} = {_fmt(v)}" for k, v in {**point, **keys}.items() if k != SEED_KEY
    )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scenario = scenario_from_dict(doc, source=path)
    except FfsmError as exc:
        raise CampaignError(f"{campaign.source}: case {index} ({what}): {exc}") from None
    text = scenario_to_toml(scenario)
    resolved = tomllib.loads(text)
    values = {}
    for col in campaign.columns:
        if col == SCENARIO_COLUMN:
            values[col] = point[col]
            continue
        given = keys.get(col) if col in keys else _lookup(doc, col)
        values[col] = _readback(_lookup(resolved, col, default=given), given)
    digest = hashlib.sha256(f"ffsm-pin {__version__}\n{text}".encode()).hexdigest()[:16]
    return Case(
        index=index,
        nominal=p is None,
        point_index=p,
        repeat=r,
        point=dict(point),
        values=values,
        estimates_seed=scenario.controller.estimates.seed,
        scenario_toml=text,
        case_hash=digest,
        scenario=scenario,
    )


# ------------------------------------------------------------------------------ helpers
def _assign(doc: dict, key: str, value: Any, source: str) -> None:
    parts = key.split(".")
    node = doc
    for i, part in enumerate(parts[:-1]):
        nxt = node.setdefault(part, {})
        if not isinstance(nxt, dict):
            prefix = ".".join(parts[: i + 1])
            raise CampaignError(f"{source}: {key}: {prefix} is a value, not a table")
        node = nxt
    node[parts[-1]] = copy.deepcopy(value)


def _readback(resolved: Any, given: Any) -> Any:
    """A per-component key (funnel entries) whose components are all equal, as a number given
    for it resolves to: record the number (:func:`expand` turns a column back into lists when
    some case's components differ)."""
    if isinstance(resolved, list) and resolved and all(_is_number(x) for x in resolved):
        if all(float(x) == float(resolved[0]) for x in resolved):
            return float(resolved[0])
    if isinstance(resolved, int) and not isinstance(resolved, bool) and isinstance(given, float):
        return float(resolved)
    return resolved


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else repr(v) if isinstance(v, str) else str(v)
