"""Campaign files (TOML, docs/campaigns.md) -> a validated :class:`Campaign` -> its cases.

A campaign names a scenario (built-in name or file) or several, a root seed, a number of repeats
per grid point, optional overrides for every case (``[campaign.set]``, ``duration``, ``dt``),
for one scenario's cases (``[campaign.set_for.<scenario>]``) and for the cases of one controller
type (``[campaign.set_for_controller."<type>"]``: a controller's own ``[controller.params]``
beside other controllers that would refuse them), grid axes
(``[[vary]]``: a dotted scenario key and its values) and randomly sampled keys (``[[sample]]``:
a dotted key and a distribution) and dispersed keys (``[campaign.disperse]``: any numeric
scenario key drawn per case, each from its own stream, read back from the case's resolved
scenario). :func:`expand` turns it into cases:

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

The file's keys, types and ranges are the pydantic models of
:mod:`ffsm_pin.sweep.campaign_schema`; this module builds the :class:`Campaign` and its cases.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import math
import sys
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from .. import __version__
from .._schema import describe, first_error, model_in
from ..control.registry import DEFAULT_TYPE
from ..errors import FfsmError, choices_text, did_you_mean
from ..scenario.file import BUILTIN, builtin_path, scenario_from_dict
from ..scenario.schema import ScenarioModel
from ..scenario.spec import Scenario
from ..scenario.writer import scenario_to_toml
from . import campaign_schema as schema
from .campaign_schema import DISTRIBUTIONS, SEED_KEY
from .seeds import case_stream, estimates_seed
from .stats import runs_for_half_width

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "BUILTIN_CAMPAIGNS",
    "AutoRepeat",
    "Campaign",
    "CampaignError",
    "Case",
    "Disperse",
    "SCENARIO_COLUMN",
    "Sample",
    "Vary",
    "builtin_campaign_path",
    "check_cases",
    "expand",
    "load_campaign",
]


#: The column of the scenario in a campaign over several scenarios.
SCENARIO_COLUMN = "scenario"
#: The scenario key that names a case's controller (``[campaign.set_for_controller]``).
TYPE_KEY = "controller.type"
#: Grid axes that do not change a case's random draws (estimates, samples, dispersions): the
#: cases of every scenario and every controller type at one grid point and repeat draw alike.
COMMON_DRAWS = (SCENARIO_COLUMN, TYPE_KEY)


class CampaignError(FfsmError, ValueError):
    """A campaign file that is missing, malformed, or makes a scenario the validation refuses."""


def _builtin_campaigns() -> dict[str, str]:
    folder = resources.files("ffsm_pin.sweep.campaigns")
    return {
        p.name[: -len(".toml")]: p.name
        for p in sorted(folder.iterdir(), key=lambda p: p.name)
        if p.name.endswith(".toml")
    }


# Built-in campaigns: name -> file in ffsm_pin/sweep/campaigns/.
BUILTIN_CAMPAIGNS: dict[str, str] = _builtin_campaigns()


def builtin_campaign_path(name: str) -> Path:
    """Path of a shipped campaign file."""
    return Path(str(resources.files("ffsm_pin.sweep.campaigns").joinpath(BUILTIN_CAMPAIGNS[name])))


@dataclass(frozen=True)
class Vary:
    """One grid axis: a dotted scenario key and its values (in file order)."""

    key: str
    values: tuple[Any, ...]


@dataclass(frozen=True)
class Sample:
    """A key drawn per case from a distribution: ``uniform(low, high)``, ``normal(mean, std)``
    or ``log-uniform(low, high)`` (log of the value uniform)."""

    key: str
    distribution: str
    params: tuple[float, float]

    def draw(self, rng: np.random.Generator) -> float:
        """One value of the distribution from ``rng``."""
        a, b = self.params
        if self.distribution == "uniform":
            return float(rng.uniform(a, b))
        if self.distribution == "normal":
            return float(rng.normal(a, b))
        return float(math.exp(rng.uniform(math.log(a), math.log(b))))


@dataclass(frozen=True)
class AutoRepeat:
    """``repeat = "auto"``: batches of repeats until the 95 % Wilson interval of every grid
    point's funnel-keeping rate is no wider than +- ``target_half_width``, or ``max_repeat``
    draws per grid point (:mod:`ffsm_pin.sweep.auto_repeat`)."""

    target_half_width: float = 0.05
    max_repeat: int = 400  # +- 0.05 at a rate of 1/2 takes 381 runs

    def first_batch(self) -> int:
        """The first batch: the fewest runs whose Wilson interval can be as narrow as the
        target."""
        return min(self.max_repeat, runs_for_half_width(0.0, self.target_half_width))


@dataclass(frozen=True)
class Disperse:
    """A key of ``[campaign.disperse]`` drawn per case: ``uniform`` (low, high), ``normal``
    (mean, std), element-wise where a bound is a list or the key's value is one, or ``angle``
    (a rotation of this angle [rad] about a uniformly random axis: a 3-vector, or a planar
    angle of random sign)."""

    key: str
    distribution: str
    params: tuple[Any, ...]

    def draw(self, rng: np.random.Generator, size: int | None) -> float | list[float]:
        """One value from ``rng``: a number (``size`` None) or ``size`` numbers."""
        if self.distribution == "angle":
            (angle,) = self.params
            if size is None:
                return float(angle * rng.choice((-1.0, 1.0)))
            axis = rng.normal(size=size)
            return [float(x) for x in angle * axis / np.linalg.norm(axis)]
        a, b = (np.asarray(x, dtype=float) for x in self.params)
        shape = () if size is None else (size,)
        a, b = np.broadcast_to(a, shape), np.broadcast_to(b, shape)
        x = rng.uniform(a, b) if self.distribution == "uniform" else rng.normal(a, b)
        return float(x) if size is None else [float(v) for v in np.atleast_1d(x)]

    def size(self) -> int | None:
        """The number of values a list bound asks for (None: numbers only)."""
        sizes = {len(x) for x in self.params if isinstance(x, list)}
        return sizes.pop() if sizes else None


@dataclass(frozen=True)
class Campaign:
    """A parsed, validated campaign file."""

    name: str
    scenarios: tuple[str, ...]  # as written: built-in names or paths
    scenario_paths: tuple[Path, ...]  # the scenario files they resolve to
    seed: int
    repeat: int
    duration: float | None
    dt: float | None
    set: Mapping[str, Any]
    vary: tuple[Vary, ...]
    sample: tuple[Sample, ...]
    source: str  # campaign file path (for messages)
    text: str  # the campaign file's text
    description: str = ""
    set_for: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)  # per scenario
    auto: AutoRepeat | None = None  # repeat = "auto"; ``repeat`` is then the current batch's
    disperse: tuple[Disperse, ...] = ()  # [campaign.disperse], drawn per case
    # per controller type (as written in controller.type)
    set_for_controller: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    @property
    def scenario(self) -> str:
        """The scenario (the first one of a campaign over several)."""
        return self.scenarios[0]

    @property
    def scenario_path(self) -> Path:
        """The file of :attr:`scenario`."""
        return self.scenario_paths[0]

    @property
    def axes(self) -> tuple[str, ...]:
        """The grid axes a report groups by: ``scenario`` first when there are several."""
        first = (SCENARIO_COLUMN,) if len(self.scenarios) > 1 else ()
        return first + tuple(v.key for v in self.vary)

    @property
    def columns(self) -> tuple[str, ...]:
        """Keys that get a column in results.parquet (``scenario`` when there are several,
        the varied keys, the sampled ones, then the dispersed ones)."""
        return self.axes + tuple(s.key for s in self.sample) + tuple(d.key for d in self.disperse)

    @property
    def n_cases(self) -> int:
        """Cases the campaign runs: per scenario, the nominal case and the grid times
        ``repeat``."""
        grid = math.prod(len(v.values) for v in self.vary) * self.repeat
        return len(self.scenarios) * (1 + grid)


@dataclass(frozen=True)
class Case:
    """One run of a campaign."""

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


# ------------------------------------------------------------------------------ loading
def load_campaign(spec: str | Path) -> Campaign:
    """A built-in campaign name or a campaign file path -> :class:`Campaign` (validated).

    Raises
    ------
    CampaignError
        Missing file, bad TOML, unknown or duplicated keys, wrong types, empty values,
        ``repeat`` < 1, unknown scenario (every message starts with the campaign file).
    """
    if isinstance(spec, str) and spec in BUILTIN_CAMPAIGNS:
        path = builtin_campaign_path(spec)
    else:
        path = Path(spec)
        if not path.is_file():
            what = "is a folder, not a file" if path.is_dir() else "not found"
            raise CampaignError(
                f"campaign {str(spec)!r}: {what}; a campaign is a TOML file or a built-in name "
                f"({choices_text(BUILTIN_CAMPAIGNS)}){did_you_mean(str(spec), BUILTIN_CAMPAIGNS)}"
            )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CampaignError(f"cannot read campaign file {str(path)!r}: {exc}") from None
    return campaign_from_toml(text, path)


def campaign_from_toml(text: str, path: Path) -> Campaign:
    """Parse and validate campaign TOML text (``path``: its file, for relative scenarios)."""
    where = str(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{where}: invalid TOML: {exc}") from None
    try:
        return _campaign(data, path, text)
    except CampaignError as exc:
        raise CampaignError(f"{where}: {exc}") from None


def _campaign(d: Mapping, path: Path, text: str) -> Campaign:
    """Validated by :class:`~ffsm_pin.sweep.campaign_schema.CampaignModel`."""
    try:
        m = schema.CampaignModel.model_validate(d)
    except ValidationError as exc:
        raise CampaignError(first_error(exc, schema.CampaignModel)) from None
    c = m.campaign
    scenarios = tuple(c.scenario) if isinstance(c.scenario, list) else (c.scenario,)
    paths = tuple(_scenario_path(x, path) for x in scenarios)
    if c.set_for_controller:
        kinds = _controller_types(scenarios, paths, c.set, c.set_for, m.vary)
        for kind in c.set_for_controller:
            if kind not in kinds:
                raise CampaignError(
                    f"campaign.set_for_controller.{schema.toml_key(kind)}: not a controller type "
                    f"of this campaign's cases{did_you_mean(kind, kinds)}; valid choices: "
                    f"{choices_text(kinds)} (controller.type as the campaign or its scenarios "
                    "write it)"
                )
    auto, repeat = None, c.repeat
    if c.repeat == "auto":
        default = AutoRepeat()
        auto = AutoRepeat(
            default.target_half_width if c.target_half_width is None else c.target_half_width,
            default.max_repeat if c.max_repeat is None else c.max_repeat,
        )
        repeat = auto.first_batch()
    return Campaign(
        name=c.name or path.stem,
        scenarios=scenarios,
        scenario_paths=paths,
        set_for={k: dict(v) for k, v in c.set_for.items()},
        set_for_controller={k: dict(v) for k, v in c.set_for_controller.items()},
        seed=c.seed,
        repeat=int(repeat),
        duration=c.duration,
        dt=c.dt,
        set=c.set,
        vary=tuple(Vary(v.key, tuple(v.values)) for v in m.vary),
        sample=tuple(
            Sample(
                s.key, s.distribution, tuple(getattr(s, k) for k in DISTRIBUTIONS[s.distribution])
            )
            for s in m.sample
        ),
        source=str(path),
        text=text,
        description=c.description,
        auto=auto,
        disperse=tuple(
            Disperse(key, spec["distribution"], tuple(spec["params"]))
            for key, spec in c.disperse.items()
        ),
    )


def _controller_types(scenarios, paths, common, set_for, vary) -> list[str]:
    """The ``controller.type`` of the campaign's grid cases, as written: the varied values,
    else ``[campaign.set_for.<scenario>]``'s, ``[campaign.set]``'s or the scenario file's (the
    default type when it names none), in the order first met."""
    kinds: list[str] = []
    varied = next((v.values for v in vary if v.key == TYPE_KEY), None)
    for name, path in zip(scenarios, paths, strict=True):
        if varied is not None:
            found = list(varied)
        elif TYPE_KEY in set_for.get(name, {}):
            found = [set_for[name][TYPE_KEY]]
        elif TYPE_KEY in common:
            found = [common[TYPE_KEY]]
        else:
            found = [_type_of(path)]
        kinds += [k for k in found if isinstance(k, str) and k not in kinds]
    return kinds


def _type_of(path: Path) -> Any:
    """The ``controller.type`` a scenario file writes (the default when none; None when the
    file cannot be read: expanding the campaign says why)."""
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    return _lookup(doc, TYPE_KEY, DEFAULT_TYPE)


def _scenario_path(scenario: str, campaign_path: Path) -> Path:
    if scenario in BUILTIN:
        return builtin_path(scenario)
    path = Path(scenario)
    if not path.is_absolute():
        path = campaign_path.parent / path
    if not path.is_file():
        raise CampaignError(
            f"campaign.scenario: {scenario!r} is neither a built-in scenario "
            f"({choices_text(BUILTIN)}){did_you_mean(scenario, BUILTIN)} nor a file "
            f"(looked for {str(path)!r})"
        )
    return path


# ------------------------------------------------------------------------------ expansion
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
            # every scenario and every controller type draws the same seeds (common random
            # numbers: the paired comparison of the report compares controllers on the same
            # draws; a campaign over one scenario and one controller draws what it drew before)
            grid = {k: v for k, v in point.items() if k != SCENARIO_COLUMN}
            draws = {k: v for k, v in grid.items() if k not in COMMON_DRAWS}
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


def check_cases(cases: list[Case], source: str) -> None:
    """Run :func:`ffsm_pin.sim.setup.prepare` (robot, feasibility, initial errors inside the
    funnels, estimates) on the nominal case and on the first case of every grid point, so a
    value that only the run set-up refuses is bad input before anything runs."""
    from ..sim.run import prepare

    checked: set[int | None] = set()
    for case in cases:
        if case.point_index in checked and not case.nominal:
            continue
        checked.add(case.point_index)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                prepare(case.scenario)
        except FfsmError as exc:
            text = str(exc)
            if text.startswith("controller.params.") and "unknown for controller.type" in text:
                text += (  # another type's keys, set for every case?
                    "; a campaign sets the keys of one controller type's cases in "
                    '[campaign.set_for_controller."<type>"]'
                )
            raise CampaignError(f"{source}: case {case.index} ({case.label()}): {text}") from None


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


def _lookup(doc: Mapping, key: str, default: Any = None) -> Any:
    node: Any = doc
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return default
        node = node[part]
    return node


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


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else repr(v) if isinstance(v, str) else str(v)
