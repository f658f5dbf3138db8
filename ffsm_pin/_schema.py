"""Building blocks of the file schemas (pydantic v2): one table model, value types, errors.

The scenario file (:mod:`ffsm_pin.scenario.schema`), the campaign file
(:mod:`ffsm_pin.sweep.campaign_schema`) and a controller's own keys (the lu-jia controller's,
:mod:`ffsm_pin.control.lu_jia_params`) are built from these, so that every one of them refuses
unknown keys, is strict about types and reports its errors through :func:`first_error` in the
same one-line form. They live below every layer, as the controllers that declare keys are
below the scenario that holds them.

:func:`first_error` turns a ``pydantic.ValidationError`` of a document validated by any of
these models into the one-line message that starts with the TOML key path
(``controller.funnel.rho_b0[0]: ...``), with the valid choices or keys and a did-you-mean hint;
:func:`fail` raises the errors it reads back (a message after the key path).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from typing import Annotated, Any, NoReturn

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, Tag, ValidationError
from pydantic_core import PydanticCustomError

from .errors import choices_text, did_you_mean


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


class Table(BaseModel):
    """A TOML table: unknown keys refused, strict types, frozen."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


# ------------------------------------------------------------------------------ one-line errors
def key_path(loc: tuple) -> str:
    """``("controller", "funnel", "rho_b0", 0)`` -> ``controller.funnel.rho_b0[0]``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif not part.startswith("<"):  # union tags of NumOrVec
            out += f".{part}" if out else part
    return out


def _model_at(loc: tuple, root: type[BaseModel]) -> type[BaseModel] | None:
    """The model class of the table at ``loc`` (for the valid keys of an unknown key); a part
    ``"<tag>"`` picks the member of a tagged union."""
    model: Any = root
    annotation: Any = None
    for part in loc:
        if isinstance(part, int):
            continue
        if part.startswith("<"):
            model = model_in(annotation, part)
        else:
            field = model.model_fields.get(part) if model is not None else None
            if field is None:
                return None
            annotation = field.annotation
            model = model_in(annotation)
    return model


def model_in(annotation: Any, tag: str | None = None) -> type[BaseModel] | None:
    """The first model class in an annotation (or the union member tagged ``tag``)."""
    if tag is None and isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if tag is not None and any(
        isinstance(m, Tag) and m.tag == tag for m in getattr(annotation, "__metadata__", ())
    ):
        return model_in(annotation.__args__[0])
    for arg in getattr(annotation, "__args__", ()):
        found = model_in(arg, tag)
        if found is not None:
            return found
    return None


def _hint(name: str, choices) -> str:
    """Did-you-mean text: a valid key that the name starts with (or that starts with the name)
    first, else the closest spelling."""
    for choice in choices:
        if len(choice) >= 3 and (name.startswith(choice) or choice.startswith(name)):
            return f" (did you mean '{choice}'?)"
    return did_you_mean(name, choices)


_NUMBER = {"float_type", "float_parsing", "int_from_float"}
_WORDS = {
    "int_type": "an integer",
    "bool_type": "true or false",
    "string_type": "a string",
    "dict_type": "a table of name = value",
    "list_type": "a list",
}
_BOUND = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def message(err: Mapping[str, Any], root: type[BaseModel]) -> str:
    """One line for one pydantic error (a ``ValidationError.errors()`` entry) of a document
    validated by the model ``root``."""
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    loc = tuple(err["loc"]) + tuple(ctx.get("at", ()))
    path = key_path(loc)
    if kind == "scenario":
        return f"{path}{ctx['text']}"
    if kind == "extra_forbidden":
        where, key = loc[:-1], str(loc[-1])
        model = _model_at(where, root)
        keys = list(model.model_fields) if model is not None else []
        what = "section" if isinstance(value, Mapping) else "key"
        place = f"in [{key_path(where)}]" if where else "at the top level"
        return f"{path}: unknown {what} {place}{_hint(key, keys)}; valid keys: {choices_text(keys)}"
    if kind == "missing":
        return f"{path}: missing (required key)"
    if kind == "literal_error":
        if not isinstance(value, str):
            return f"{path}: expected a string, got {describe(value)}"
        choices = re.findall(r"'([^']*)'", ctx.get("expected", ""))
        verb = "is not supported" if path == "robot.base" else "unknown"
        return (
            f"{path} = {value!r} {verb}{did_you_mean(value, choices)}; "
            f"valid choices: {choices_text(choices)}"
        )
    if kind in _NUMBER:
        if loc and isinstance(loc[-1], int):
            at = key_path(loc[:-1])
            return f"{at}: expected a list of numbers, [{loc[-1]}] is {describe(value)}"
        return f"{path}: expected a number, got {describe(value)}"
    if kind == "finite_number":
        return f"{path} = {value}: must be finite"
    if kind in _BOUND:
        bound = next(iter(ctx.values()))
        bound = f"{bound:g}" if _is_number(bound) else bound
        return f"{path} = {value}: must be {_BOUND[kind]} {bound}"
    if kind in ("too_short", "too_long"):
        n = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        if kind == "too_short" and n == 1:
            return f"{path}: empty; give at least one value"
        return f"{path}: {ctx.get('actual_length')} values, expected {n}"
    if kind == "model_type":
        return f"{path}: expected a table [{path}], got {describe(value)}"
    if kind in _WORDS:
        return f"{path}: expected {_WORDS[kind]}, got {describe(value)}"
    return f"{path}: {err.get('msg', 'invalid value')}"  # pragma: no cover - a new pydantic type


def first_error(exc: ValidationError, root: type[BaseModel]) -> str:
    """The first error as one line (unknown keys first, like a reader scanning the file), and
    how many more there are."""
    errors = exc.errors(include_url=False)
    errors.sort(key=lambda e: e["type"] != "extra_forbidden")
    text = message(errors[0], root)
    if len(errors) > 1:
        text += f" (and {len(errors) - 1} more)"
    return text.replace("\n", " ")
