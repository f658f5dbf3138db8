"""Building blocks of the file schemas (pydantic v2): one table model, value types, errors.

The scenario file (:mod:`ffsm_pin.scenario.schema`), the campaign file
(:mod:`ffsm_pin.sweep.campaign_schema`) and a controller's own keys (the lu-jia controller's,
:mod:`ffsm_pin.control.lu_jia_params`) are built from these, so that every one of them refuses
unknown keys, is strict about types and reports its errors through
:func:`ffsm_pin.scenario.schema.first_error` in the same one-line form. They live below every
layer, as the controllers that declare keys are below the scenario that holds them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Annotated, Any, NoReturn

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field
from pydantic_core import PydanticCustomError


def fail(at: tuple, text: str) -> NoReturn:
    """Raise a validation error at ``loc + at``; the message is the key path followed by
    ``text`` (``": 2 values, expected 3"``, ``" = 1.5: must be in (0, 1]"``)."""
    raise PydanticCustomError("scenario", "{text}", {"text": text, "at": at})


def describe(x: Any) -> str:
    """A value and its TOML kind, shortened: ``'fast' (string)``."""
    names = {bool: "boolean", int: "integer", float: "number", str: "string", list: "list"}
    kind = names.get(type(x), "table" if isinstance(x, Mapping) else type(x).__name__)
    text = repr(x)
    return f"{text[:60] + '...' if len(text) > 60 else text} ({kind})"


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def default(cls: type, name: str) -> Any:
    """The default of field ``name`` of the dataclass ``cls``: the dataclasses hold every
    default once, the file's models read them from there (a tuple as the list TOML has)."""
    f: Any = {f.name: f for f in dataclasses.fields(cls)}[name]
    value = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    return list(value) if isinstance(value, tuple) else value


Num = Annotated[float, Field(allow_inf_nan=False)]  # int accepted, bool and str are not
Pos = Annotated[float, Field(gt=0, allow_inf_nan=False)]


def _numbers(value: Any) -> Any:
    if not isinstance(value, list) or not all(_is_number(x) for x in value):
        fail((), f": expected a list of numbers, got {describe(value)}")
    return value


Vec = Annotated[list[Num], BeforeValidator(_numbers)]


class _Table(BaseModel):
    """A TOML table: unknown keys refused, strict types, frozen."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)
