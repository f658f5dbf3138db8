"""The campaign file (docs/campaigns.md) as pydantic v2 models: ``[campaign]`` (with
``[campaign.disperse]``), ``[[vary]]``, ``[[sample]]`` (one model per distribution). Errors
become one line through :func:`ffsm_pin._schema.first_error`, like the scenario
file's."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BeforeValidator, Discriminator, Field, Tag, model_validator

from .._schema import Num, Pos, Table, describe, fail
from ..errors import choices_text, did_you_mean

SEED_KEY = "controller.estimates.seed"
DISTRIBUTIONS = {
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "log-uniform": ("low", "high"),
}


def flatten(table: Mapping, prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` and ``{"a.b": 1}`` both -> ``{"a.b": 1}`` (quoted or dotted keys).

    Parameters
    ----------
    table : mapping
        Nested or dotted keys.
    prefix : str
        Prepended to every key.

    Returns
    -------
    dict
        Dotted keys to values.
    """
    out: dict[str, Any] = {}
    for k, v in table.items():
        full = f"{prefix}.{k}" if prefix else k
        if isinstance(v, Mapping):
            out.update(flatten(v, full))
        else:
            if full in out:
                fail((), f": {full} given twice")
            out[full] = v
    return out


def same(a: Any, b: Any) -> bool:
    """Equal values (1 and 1.0 are the same number; True is not 1).

    Parameters
    ----------
    a, b : object
        Two values.

    Returns
    -------
    bool
        True when they are the same value.
    """
    numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (a, b))
    return float(a) == float(b) if numbers else type(a) is type(b) and a == b


def _values(values: Any) -> Any:
    if not isinstance(values, list) or not values:
        fail((), f": expected a non-empty list of values, got {describe(values)}")
    for i, x in enumerate(values):
        if any(same(x, y) for y in values[:i]):
            fail((), f": {x!r} appears twice")
    return values


def _distribution(table: Any) -> Any:
    dist = table.get("distribution") if isinstance(table, Mapping) else None
    if isinstance(table, Mapping) and dist not in DISTRIBUTIONS:
        what = (
            "missing"
            if dist is None
            else f"{dist!r} unknown{did_you_mean(str(dist), DISTRIBUTIONS)}"
        )
        fail(("distribution",), f": {what}; valid choices: {choices_text(DISTRIBUTIONS)}")
    return table


Key = Annotated[str, Field(min_length=1)]  # a dotted scenario key


def _scenarios(value: Any) -> Any:
    if isinstance(value, list):
        if not value or not all(isinstance(x, str) and x for x in value):
            fail(
                (), f": expected a scenario or a non-empty list of scenarios, got {describe(value)}"
            )
        for i, x in enumerate(value):
            if x in value[:i]:
                fail((), f": {x!r} appears twice")
    return value


def _tables_per(what: str):
    """A table of tables (one per ``what``), each flattened to dotted keys."""

    def check(table: Any) -> Any:
        if not isinstance(table, Mapping) or not all(
            isinstance(v, Mapping) for v in table.values()
        ):
            fail((), f": expected a table of tables (one per {what}), got {describe(table)}")
        return {name: flatten(v) for name, v in table.items()}

    return check


def toml_key(name: str) -> str:
    """``name`` as a TOML key: bare when it may be, else quoted (``"my_ctrl.py:MyController"``)."""
    return name if name and name.replace("_", "").replace("-", "").isalnum() else f'"{name}"'


def _repeat(value: Any) -> Any:
    if value == "auto":
        return value
    if not isinstance(value, int) or isinstance(value, bool):
        fail((), f': expected an integer >= 1 or "auto", got {describe(value)}')
    if value < 1:
        fail((), f" = {value}: must be >= 1")
    return value


#: ``[campaign.disperse]`` forms: a key's value drawn per case (docs/campaigns.md).
DISPERSIONS = {
    "uniform": "[low, high]",
    "normal": "[mean, std]",
    "angle": "an angle [rad] in a random direction",
}


def _is_num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _bound(x: Any, at: tuple, what: str) -> Any:
    """A number or a non-empty list of numbers (an element-wise bound)."""
    if _is_num(x) or (isinstance(x, list) and x and all(_is_num(v) for v in x)):
        return x
    fail(at, f": {what} must be a finite number or a list of them, got {describe(x)}")


def _dispersion(key: str, spec: Any) -> dict[str, Any]:
    """One ``[campaign.disperse]`` entry checked: ``{ uniform = [a, b] }``,
    ``{ normal = [mean, std] }`` or ``{ angle = a }``."""
    at: tuple = (key,)
    if not isinstance(spec, Mapping) or len(spec) != 1:
        fail(at, f": expected one of {{ uniform = [low, high] }}, {{ normal = [mean, std] }} or "
             f"{{ angle = a }}, got {describe(spec)}")  # fmt: skip
    ((dist, params),) = spec.items()
    if dist not in DISPERSIONS:
        fail(at, f": unknown distribution {dist!r}{did_you_mean(str(dist), DISPERSIONS)}; "
             f"valid choices: {choices_text(DISPERSIONS)}")  # fmt: skip
    at = (key, dist)
    if dist == "angle":
        if not (_is_num(params) and 0 < params <= math.pi):
            fail(at, f" = {params!r}: must be an angle in (0, pi] [rad]")
        return {"distribution": dist, "params": (float(params),)}
    names = DISPERSIONS[dist]
    if not (isinstance(params, list) and len(params) == 2):
        fail(at, f": expected {names}, got {describe(params)}")
    a, b = (_bound(x, at, n) for x, n in zip(params, names[1:-1].split(", "), strict=True))
    sizes = {len(x) for x in (a, b) if isinstance(x, list)}
    if len(sizes) > 1:
        fail(at, f": {names} have {' and '.join(str(n) for n in sorted(sizes))} values; give "
             "lists of one length (or numbers, used for every component)")  # fmt: skip
    n = sizes.pop() if sizes else 0
    lo = a if isinstance(a, list) else [a] * max(n, 1)
    hi = b if isinstance(b, list) else [b] * max(n, 1)
    for i, (x, y) in enumerate(zip(lo, hi, strict=True)):
        where = f"[{i}]" if n else ""
        if dist == "uniform" and not x < y:
            fail(at, f": bounds in the wrong order: low{where} = {x} must be < high{where} = {y}")
        if dist == "normal" and not y > 0:
            fail(at, f": std{where} = {y} must be > 0")
    return {"distribution": dist, "params": (a, b)}


def _disperse(table: Any) -> Any:
    """``[campaign.disperse]``: dotted keys (quoted, or nested tables) to their dispersions."""
    if not isinstance(table, Mapping):
        fail((), f": expected a table of key = {{ distribution = ... }}, got {describe(table)}")
    out: dict[str, Any] = {}

    def walk(node: Mapping, prefix: str) -> None:
        for k, v in node.items():
            full = f"{prefix}.{k}" if prefix else str(k)
            nested = (
                isinstance(v, Mapping) and v and all(isinstance(x, Mapping) for x in v.values())
            )
            if nested:
                walk(v, full)
            elif full in out:
                fail((), f": {full} given twice")
            else:
                out[full] = _dispersion(full, v)

    walk(table, "")
    return out


class CampaignTable(Table):
    """``[campaign]``: the scenario(s), per-scenario overrides and the run settings."""

    # a built-in scenario name or a file (relative to the campaign file), or a list of them
    scenario: Annotated[str | list[str], BeforeValidator(_scenarios)]
    # {scenario: {dotted key: value}}: overrides for that scenario's cases only
    set_for: Annotated[dict[str, dict[str, Any]], BeforeValidator(_tables_per("scenario"))] = {}
    # {controller type: {dotted key: value}}: overrides for the cases of that controller.type
    set_for_controller: Annotated[
        dict[str, dict[str, Any]], BeforeValidator(_tables_per("controller type"))
    ] = {}
    name: str | None = None  # default: the file's stem
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    # draws per grid point, or "auto": batches until the rates' 95 % Wilson intervals are no
    # wider than +- target_half_width at every grid point, or max_repeat draws
    repeat: Annotated[int | Literal["auto"], BeforeValidator(_repeat)] = 1
    target_half_width: Annotated[float, Field(gt=0, lt=0.5, allow_inf_nan=False)] | None = None
    max_repeat: Annotated[int, Field(ge=1)] | None = None
    duration: Pos | None = None  # [s]
    dt: Pos | None = None  # [s]
    set: Annotated[dict[str, Any], AfterValidator(flatten)] = {}
    # {dotted key: {"distribution", "params"}}: drawn per case from the key's own stream
    disperse: Annotated[dict[str, Any], BeforeValidator(_disperse)] = {}

    @model_validator(mode="after")
    def auto_keys(self):
        """target_half_width and max_repeat only with repeat = "auto"."""
        for key in ("target_half_width", "max_repeat"):
            if getattr(self, key) is not None and self.repeat != "auto":
                fail((key,), ': only with repeat = "auto"')
        return self


class VaryTable(Table):
    """One ``[[vary]]`` axis of the grid: a dotted scenario key and its values."""

    key: Key
    values: Annotated[list[Any], BeforeValidator(_values)]


class Uniform(Table):
    """A ``[[sample]]`` key drawn uniformly from [low, high]."""

    key: Key
    distribution: Literal["uniform"]
    low: Num
    high: Num

    @model_validator(mode="after")
    def low_below_high(self):
        """Refuse an empty interval."""
        if not self.low < self.high:
            fail((), f": low = {self.low} must be < high = {self.high}")
        return self


class LogUniform(Uniform):
    """A ``[[sample]]`` key whose logarithm is uniform on [log low, log high], low > 0."""

    distribution: Literal["log-uniform"]  # type: ignore[assignment]
    low: Pos  # log-uniform needs low > 0


class Normal(Table):
    """A ``[[sample]]`` key drawn from a normal distribution (mean, std > 0)."""

    key: Key
    distribution: Literal["normal"]
    mean: Num
    std: Pos


SampleTable = Annotated[
    Annotated[Uniform, Tag("<uniform>")]
    | Annotated[Normal, Tag("<normal>")]
    | Annotated[LogUniform, Tag("<log-uniform>")],
    Discriminator(lambda t: f"<{t.get('distribution')}>" if isinstance(t, Mapping) else None),
    BeforeValidator(_distribution),
]


class CampaignModel(Table):
    """A whole campaign file; the validator refuses a key given twice or set by the campaign."""

    campaign: CampaignTable = Field(default_factory=dict, validate_default=True)
    vary: list[VaryTable] = []
    sample: list[SampleTable] = []

    @model_validator(mode="after")
    def keys_once(self):
        """Refuse a key given twice, or one the campaign itself sets."""
        where: dict[str, str] = {}
        c = self.campaign
        names = c.scenario if isinstance(c.scenario, list) else [c.scenario]
        for name, keys in c.set_for.items():
            if name not in names:
                fail(("campaign", "set_for", name), f": not a scenario of this campaign; "
                     f"valid choices: {choices_text(names)}")  # fmt: skip
            varied = {v.key for v in self.vary}
            for key in keys:
                if key in c.set or key == SEED_KEY or key in varied or key in c.disperse:
                    why = ": also set for every case (campaign.set, [[vary]] or the seed)"
                    fail(("campaign", "set_for", name, key), why)
        self._per_controller(where_set_for={
            key: name for name, keys in c.set_for.items() for key in keys
        })  # fmt: skip
        for key, place in [
            *((k, "campaign.set") for k in c.set),
            *((v.key, "[[vary]]") for v in self.vary),
            *((s.key, "[[sample]]") for s in self.sample),
            *((k, "campaign.disperse") for k in c.disperse),
        ]:
            if key in where:
                fail((key,), f": given twice (in {where[key]} and in {place})")
            where[key] = place
            if key == SEED_KEY:
                fail((key,), ": set by the campaign for every case (from campaign.seed, its "
                     "grid point and its repeat index); use campaign.seed and campaign.repeat "
                     "instead")  # fmt: skip
            for opt, full in (("duration", "sim.duration"), ("dt", "sim.dt")):
                if key == full and getattr(c, opt) is not None:
                    fail((key,), f": given twice (in {place} and as campaign.{opt})")
        return self

    def _per_controller(self, where_set_for: Mapping[str, str]) -> None:
        """Refuse a key of ``[campaign.set_for_controller."<type>"]`` that every case sets,
        that a scenario's table sets too, or ``controller.type`` itself (which controller types
        the campaign has is checked where its scenario files are read)."""
        c = self.campaign
        everywhere = {
            *c.set,
            *c.disperse,
            *(v.key for v in self.vary),
            *(s.key for s in self.sample),
        }
        for opt in ("duration", "dt"):
            if getattr(c, opt) is not None:
                everywhere.add(f"sim.{opt}")
        for kind, keys in c.set_for_controller.items():
            at = ("campaign", "set_for_controller", toml_key(kind))
            for key in keys:
                if key == "controller.type":
                    fail((*at, key), ": the controller type is what picks this table's cases; "
                         "set it in [[vary]], campaign.set or the scenario")  # fmt: skip
                if key in everywhere or key == SEED_KEY:
                    why = (": also set for every case (campaign.set, [[vary]], [[sample]], "
                           "[campaign.disperse], campaign.duration / dt or the seed)")  # fmt: skip
                    fail((*at, key), why)
                if key in where_set_for:
                    scenario = toml_key(where_set_for[key])
                    fail((*at, key), f": given twice (also in campaign.set_for.{scenario})")
