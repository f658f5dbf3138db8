"""Campaign files (TOML, docs/campaigns.md) -> a validated :class:`Campaign`.

A campaign names a scenario (built-in name or file) or several, a root seed, a number of repeats
per grid point, optional overrides for every case (``[campaign.set]``, ``duration``, ``dt``),
for one scenario's cases (``[campaign.set_for.<scenario>]``) and for the cases of one controller
type (``[campaign.set_for_controller."<type>"]``: a controller's own ``[controller.params]``
beside other controllers that would refuse them), grid axes
(``[[vary]]``: a dotted scenario key and its values) and randomly sampled keys (``[[sample]]``:
a dotted key and a distribution) and dispersed keys (``[campaign.disperse]``: any numeric
scenario key drawn per case, each from its own stream, read back from the case's resolved
scenario). :func:`ffsm_pin.sweep.cases.expand` turns it into cases.

The file's keys, types and ranges are the pydantic models of
:mod:`ffsm_pin.sweep.campaign_schema`; this module builds the :class:`Campaign`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from .._schema import first_error
from ..control.registry import DEFAULT_TYPE
from ..errors import FfsmError, choices_text, did_you_mean
from ..scenario.file import BUILTIN, builtin_path
from . import campaign_schema as schema
from .campaign_schema import DISTRIBUTIONS
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
    "Disperse",
    "SCENARIO_COLUMN",
    "Sample",
    "Vary",
    "builtin_campaign_path",
    "campaign_from_toml",
    "load_campaign",
]


#: The column of the scenario in a campaign over several scenarios.
SCENARIO_COLUMN = "scenario"
#: The scenario key that names a case's controller (``[campaign.set_for_controller]``).
TYPE_KEY = "controller.type"


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
    """One grid axis: a dotted scenario key and its values (in file order).

    Attributes
    ----------
    key : str
        The dotted scenario key.
    values : tuple
        Its values, in file order.
    """

    key: str
    values: tuple[Any, ...]


@dataclass(frozen=True)
class Sample:
    """A key drawn per case from a distribution: ``uniform(low, high)``, ``normal(mean, std)``
    or ``log-uniform(low, high)`` (log of the value uniform).

    Attributes
    ----------
    key : str
        The dotted scenario key.
    distribution : str
        ``"uniform"``, ``"normal"`` or ``"log-uniform"``.
    params : tuple of float
        The distribution's two parameters.
    """

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
    draws per grid point (:mod:`ffsm_pin.sweep.auto_repeat`).

    Attributes
    ----------
    target_half_width : float
        Half-width of the Wilson interval aimed at.
    max_repeat : int
        Most draws per grid point (+- 0.05 at a rate of 1/2 takes 381 runs).
    """

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
    angle of random sign).

    Attributes
    ----------
    key : str
        The dotted scenario key.
    distribution : str
        ``"uniform"``, ``"normal"`` or ``"angle"``.
    params : tuple
        The distribution's parameters.
    """

    key: str
    distribution: str
    params: tuple[Any, ...]

    def draw(self, rng: np.random.Generator, size: int | None) -> float | list[float]:
        """One value from ``rng``: a number (``size`` None) or ``size`` numbers.

        Parameters
        ----------
        rng : numpy.random.Generator
            The generator.
        size : int or None
            Numbers drawn; None: one number.

        Returns
        -------
        float or list of float
            The value.
        """
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
    """A parsed, validated campaign file.

    Attributes
    ----------
    name : str
        The campaign's name.
    scenarios : tuple of str
        As written: built-in names or paths.
    scenario_paths : tuple of Path
        The scenario files they resolve to.
    seed : int
        The campaign's seed.
    repeat : int
        Repeats per grid point.
    duration : float or None
        Overrides the scenarios' duration [s].
    dt : float or None
        Overrides the scenarios' control period [s].
    set : mapping
        Scenario keys set for every case (``[campaign.set]``).
    vary : tuple of Vary
        The grid axes.
    sample : tuple of Sample
        Keys drawn per case.
    source : str
        Campaign file path (for messages).
    text : str
        The campaign file's text.
    description : str
        Free text.
    set_for : mapping
        Keys set per scenario (``[campaign.set_for.<scenario>]``).
    auto : AutoRepeat or None
        ``repeat = "auto"``; ``repeat`` is then the current batch's.
    disperse : tuple of Disperse
        ``[campaign.disperse]``, drawn per case.
    set_for_controller : mapping
        Keys set per controller type, as written in ``controller.type``
        (``[campaign.set_for_controller."<type>"]``).
    """

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
    """Parse and validate campaign TOML text (``path``: its file, for relative scenarios).

    Parameters
    ----------
    text : str
        Campaign TOML text.
    path : Path
        Its file.

    Returns
    -------
    Campaign
        The campaign.
    """
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


def _lookup(doc: Mapping, key: str, default: Any = None) -> Any:
    node: Any = doc
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return default
        node = node[part]
    return node
