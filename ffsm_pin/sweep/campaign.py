"""Campaign files (TOML, docs/campaigns.md) -> a validated :class:`Campaign` -> its cases.

A campaign names a scenario (built-in name or file), a root seed, a number of repeats per grid
point, optional overrides for every case (``[campaign.set]``, ``duration``, ``dt``), grid axes
(``[[vary]]``: a dotted scenario key and its values) and randomly sampled keys (``[[sample]]``:
a dotted key and a distribution). :func:`expand` turns it into cases:

* case 0 is the nominal scenario: the scenario file as it is, with only the run length and
  step applied (``duration``/``dt``, or ``sim.duration``/``sim.dt`` of ``[campaign.set]``;
  no other set, varied or sampled key, its own estimates seed);
* cases 1.. are the Cartesian product of the ``[[vary]]`` axes (in file order, the last axis
  fastest) times ``repeat`` draws, repeats innermost. Each case sets
  ``controller.estimates.seed`` and draws its sampled keys from its own random stream
  (:mod:`ffsm_pin.sweep.seeds`).

Every case's scenario is the scenario file's TOML document with the keys replaced, validated by
:func:`ffsm_pin.sim.scenario_file.scenario_from_dict` exactly like a file; the case records the
value each key has in the resolved scenario (read back from its TOML form). Its ``case_hash``
hashes that scenario's TOML text and the package version.
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

from .. import __version__
from ..errors import FfsmError, choices_text, did_you_mean
from ..sim.scenario import Scenario
from ..sim.scenario_file import BUILTIN, builtin_path, scenario_from_dict, scenario_to_toml
from .seeds import case_stream, estimates_seed

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "BUILTIN_CAMPAIGNS",
    "Campaign",
    "CampaignError",
    "Case",
    "Sample",
    "Vary",
    "builtin_campaign_path",
    "check_cases",
    "expand",
    "load_campaign",
]

SEED_KEY = "controller.estimates.seed"
DISTRIBUTIONS = {
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "log-uniform": ("low", "high"),
}
_TOP = ("campaign", "vary", "sample")
_CAMPAIGN_KEYS = ("name", "description", "scenario", "seed", "repeat", "duration", "dt", "set")


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
        a, b = self.params
        if self.distribution == "uniform":
            return float(rng.uniform(a, b))
        if self.distribution == "normal":
            return float(rng.normal(a, b))
        return float(math.exp(rng.uniform(math.log(a), math.log(b))))


@dataclass(frozen=True)
class Campaign:
    """A parsed, validated campaign file."""

    name: str
    scenario: str  # as written: a built-in name or a path
    scenario_path: Path  # the scenario file it resolves to
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

    @property
    def columns(self) -> tuple[str, ...]:
        """Dotted keys that get a column in results.parquet (varied, then sampled)."""
        return tuple(v.key for v in self.vary) + tuple(s.key for s in self.sample)

    @property
    def n_cases(self) -> int:
        return 1 + math.prod(len(v.values) for v in self.vary) * self.repeat


@dataclass(frozen=True)
class Case:
    """One run of a campaign."""

    index: int  # position in the campaign (0 = nominal)
    nominal: bool
    point_index: int | None  # grid point number (None for the nominal case)
    repeat: int | None  # repeat index within the grid point (None for the nominal case)
    point: Mapping[str, Any]  # grid point {dotted key: value as written in the campaign}
    values: Mapping[str, Any]  # {column: value the resolved scenario uses}
    estimates_seed: int
    scenario_toml: str  # the resolved scenario (loads with scenario_from_toml)
    case_hash: str
    scenario: Scenario = field(repr=False, compare=False)

    def label(self) -> str:
        if self.nominal:
            return "nominal"
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
    _known(d, _TOP, "", "section")
    c = d.get("campaign")
    if not isinstance(c, Mapping):
        raise CampaignError("[campaign]: missing table (needs at least scenario = ...)")
    _known(c, _CAMPAIGN_KEYS, "campaign", "key")
    if "scenario" not in c:
        raise CampaignError("campaign.scenario: missing (a built-in case name or a file)")
    scenario = _typed(c, "scenario", str, "campaign", "a string")
    name = _typed(c, "name", str, "campaign", "a string", default=path.stem)
    description = _typed(c, "description", str, "campaign", "a string", default="")
    seed = _typed(c, "seed", int, "campaign", "an integer", default=0)
    if seed < 0:
        raise CampaignError(f"campaign.seed = {seed}: must be >= 0")
    repeat = _typed(c, "repeat", int, "campaign", "an integer", default=1)
    if repeat < 1:
        raise CampaignError(f"campaign.repeat = {repeat}: must be >= 1 (draws per grid point)")
    duration = _positive(c, "duration")
    dt = _positive(c, "dt")
    sets = c.get("set", {})
    if not isinstance(sets, Mapping):
        raise CampaignError(f"campaign.set: expected a table of dotted keys, got {_describe(sets)}")
    sets = _flatten(sets)

    vary = []
    raw = d.get("vary", [])
    if not isinstance(raw, list) or not all(isinstance(x, Mapping) for x in raw):
        raise CampaignError(f"vary: expected [[vary]] tables, got {_describe(raw)}")
    for i, v in enumerate(raw):
        at = f"vary[{i}]"
        _known(v, ("key", "values"), at, "key")
        key = _key(v, at)
        values = v.get("values")
        if not isinstance(values, list) or not values:
            raise CampaignError(
                f"{at}.values ({key}): expected a non-empty list of values, got {_describe(values)}"
            )
        seen = []
        for x in values:
            if any(_same(x, y) for y in seen):
                raise CampaignError(f"{at}.values ({key}): {x!r} appears twice")
            seen.append(x)
        vary.append(Vary(key, tuple(values)))

    samples = []
    raw = d.get("sample", [])
    if not isinstance(raw, list) or not all(isinstance(x, Mapping) for x in raw):
        raise CampaignError(f"sample: expected [[sample]] tables, got {_describe(raw)}")
    for i, s in enumerate(raw):
        at = f"sample[{i}]"
        key = _key(s, at)
        dist = _typed(s, "distribution", str, at, "a string", default=None)
        if dist not in DISTRIBUTIONS:
            raise CampaignError(
                f"{at}.distribution ({key}): {dist!r} unknown"
                f"{did_you_mean(str(dist), DISTRIBUTIONS)}; valid choices: "
                f"{choices_text(DISTRIBUTIONS)}"
            )
        names = DISTRIBUTIONS[dist]
        _known(s, ("key", "distribution", *names), at, "key")
        params = []
        for p in names:
            if p not in s:
                raise CampaignError(f"{at}.{p}: missing ({dist} needs {', '.join(names)})")
            x = s[p]
            if not _is_number(x) or not math.isfinite(x):
                raise CampaignError(f"{at}.{p}: expected a finite number, got {_describe(x)}")
            params.append(float(x))
        a, b = params
        if dist == "normal" and not b > 0:
            raise CampaignError(f"{at}.std = {b}: must be > 0")
        if dist != "normal" and not a < b:
            raise CampaignError(f"{at}: low = {a} must be < high = {b}")
        if dist == "log-uniform" and not a > 0:
            raise CampaignError(f"{at}.low = {a}: log-uniform needs low > 0")
        samples.append(Sample(key, dist, (a, b)))

    where: dict[str, str] = {}
    for key, place in [
        *((k, "campaign.set") for k in sets),
        *((v.key, "[[vary]]") for v in vary),
        *((s.key, "[[sample]]") for s in samples),
    ]:
        if key in where:
            raise CampaignError(f"{key}: given twice (in {where[key]} and in {place})")
        where[key] = place
        if key == SEED_KEY:
            raise CampaignError(
                f"{key}: set by the campaign for every case (from campaign.seed, its grid point "
                "and its repeat index); use campaign.seed and campaign.repeat instead"
            )
        for opt, full in (("duration", "sim.duration"), ("dt", "sim.dt")):
            if key == full and c.get(opt) is not None:
                raise CampaignError(f"{key}: given twice (in {place} and as campaign.{opt})")
    return Campaign(
        name=name,
        scenario=scenario,
        scenario_path=_scenario_path(scenario, path),
        seed=seed,
        repeat=repeat,
        duration=duration,
        dt=dt,
        set=sets,
        vary=tuple(vary),
        sample=tuple(samples),
        source=str(path),
        text=text,
        description=description,
    )


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
    try:
        base = tomllib.loads(campaign.scenario_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise CampaignError(
            f"{campaign.source}: scenario {str(campaign.scenario_path)!r}: {exc}"
        ) from None
    common = {}  # run length and step, also for the nominal case (comparable rows)
    for opt, full in (("duration", "sim.duration"), ("dt", "sim.dt")):
        if getattr(campaign, opt) is not None:
            common[full] = getattr(campaign, opt)
        elif full in campaign.set:
            common[full] = campaign.set[full]
    cases = [
        _case(campaign, base, 0, None, None, {}, common, _seed_of(base), label="nominal scenario")
    ]
    points = list(itertools.product(*(v.values for v in campaign.vary)))
    for p, values in enumerate(points):
        point = {v.key: x for v, x in zip(campaign.vary, values, strict=True)}
        for r in range(campaign.repeat):
            seed = estimates_seed(campaign.seed, point, r)
            keys = {**common, **campaign.set, **point, SEED_KEY: seed}
            for s in campaign.sample:
                rng = np.random.default_rng(case_stream(campaign.seed, point, r, "sample:" + s.key))
                keys[s.key] = s.draw(rng)
            index = len(cases)
            cases.append(_case(campaign, base, index, p, r, point, keys, seed))
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


def _seed_of(doc: Mapping) -> int:
    seed = doc.get("controller", {}).get("estimates", {}).get("seed", 0)
    return seed if isinstance(seed, int) else 0


def _case(campaign, base, index, p, r, point, keys, seed, label=None) -> Case:
    doc = copy.deepcopy(base)
    for key, value in keys.items():
        _assign(doc, key, value, campaign.source)
    what = label or ", ".join(f"{k} = {_fmt(v)}" for k, v in keys.items() if k != SEED_KEY)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scenario = scenario_from_dict(doc, source=campaign.scenario_path)
    except FfsmError as exc:
        raise CampaignError(f"{campaign.source}: case {index} ({what}): {exc}") from None
    text = scenario_to_toml(scenario)
    resolved = tomllib.loads(text)
    values = {}
    for col in campaign.columns:
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
    """Run :func:`ffsm_pin.sim.run.prepare` (robot, feasibility, initial errors inside the
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
            raise CampaignError(f"{source}: case {case.index} ({case.label()}): {exc}") from None


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


def _flatten(table: Mapping, prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` and ``{"a.b": 1}`` both -> ``{"a.b": 1}`` (quoted or dotted keys)."""
    out: dict[str, Any] = {}
    for k, v in table.items():
        full = f"{prefix}.{k}" if prefix else k
        if isinstance(v, Mapping):
            out.update(_flatten(v, full))
        else:
            if full in out:
                raise CampaignError(f"campaign.set: {full} given twice")
            out[full] = v
    return out


def _known(table: Mapping, valid, where: str, kind: str) -> None:
    for key in table:
        if key not in valid:
            place = f"in [{where}]" if where else "at the top level"
            raise CampaignError(
                f"{where + '.' if where else ''}{key}: unknown {kind} {place}"
                f"{did_you_mean(key, valid)}; valid: {choices_text(valid)}"
            )


def _key(table: Mapping, at: str) -> str:
    key = table.get("key")
    if not isinstance(key, str) or not key:
        raise CampaignError(f"{at}.key: expected a dotted scenario key (a string), got "
                            f"{_describe(key)}")  # fmt: skip
    return key


def _typed(table: Mapping, key: str, kind, where: str, what: str, default: Any = None):
    if key not in table:
        return default
    value = table[key]
    if not isinstance(value, kind) or isinstance(value, bool):
        raise CampaignError(f"{where}.{key}: expected {what}, got {_describe(value)}")
    return value


def _positive(table: Mapping, key: str) -> float | None:
    if key not in table:
        return None
    value = table[key]
    if not _is_number(value) or not (math.isfinite(value) and value > 0):
        raise CampaignError(f"campaign.{key}: expected a positive number [s], got "
                            f"{_describe(value)}")  # fmt: skip
    return float(value)


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _same(a: Any, b: Any) -> bool:
    if _is_number(a) and _is_number(b):
        return float(a) == float(b)
    return type(a) is type(b) and a == b


def _describe(x: Any) -> str:
    names = {bool: "boolean", int: "integer", float: "number", str: "string", list: "list"}
    kind = names.get(type(x), "table" if isinstance(x, Mapping) else type(x).__name__)
    text = repr(x)
    return f"{text[:60] + '...' if len(text) > 60 else text} ({kind})"


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else repr(v) if isinstance(v, str) else str(v)
