"""The value types of the scenario file's keys (pydantic v2), beyond the shared ones of
:mod:`ffsm_pin._schema` (``Num``, ``Pos``, ``Vec``): a list of exactly n numbers, a number or a
list of them, a range, the harmonics' pairs, a torque limit (a word or numbers).
"""

# mypy: disable-error-code="valid-type"
# (the field types are built at run time; pydantic checks them)

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, Discriminator, Field, Tag

from .._schema import Num, Vec, _is_number, _numbers, describe, fail
from ..errors import did_you_mean
from .devices import LIMIT_WORDS


def _number_or_numbers(value: Any) -> Any:
    if not _is_number(value):
        _numbers(value)
    return value


def _pairs(value: Any) -> Any:
    if not isinstance(value, list):
        fail((), f": expected a list of [amplitude, frequency] pairs, got {describe(value)}")
    for j, term in enumerate(value):
        if not (isinstance(term, list) and len(term) == 2 and all(_is_number(x) for x in term)):
            fail(
                (j,),
                f": expected [amplitude, angular_frequency] (two numbers), got {describe(term)}",
            )
    return value


def _tables(value: Any) -> Any:
    if not isinstance(value, list) or not all(isinstance(x, Mapping) for x in value):
        fail(
            (),
            ": expected a list of tables like { c = 3.9, cos = [[0.1, 0.35]] }, "
            f"got {describe(value)}",
        )
    return value


def vec(n: int) -> Any:
    """A list of exactly n finite numbers."""
    return Annotated[Vec, Field(min_length=n, max_length=n)]


def or_list(item: Any) -> Any:
    """``item`` or a list of them (funnel entries broadcast, planar/spatial rates); the union's
    tags "<...>" are left out of error paths."""
    return Annotated[
        Annotated[item, Tag("<number>")] | Annotated[list[item], Tag("<list>")],
        Discriminator(lambda v: "<list>" if isinstance(v, list) else "<number>"),
        BeforeValidator(_number_or_numbers),
    ]


def interval(text: str, inside) -> AfterValidator:
    """A range check, ``inside(x)`` true, with the message "must be in <text>".

    Parameters
    ----------
    text : str
        The range, for the message (e.g. ``"(0, 1]"``).
    inside : callable
        x -> True when x is in the range.

    Returns
    -------
    AfterValidator
        The check.
    """

    def check(x: float) -> float:
        if not inside(x):
            fail((), f" = {x}: must be in {text}")
        return x

    return AfterValidator(check)


NumOrVec = or_list(Num)
NonNeg = Annotated[float, Field(ge=0, allow_inf_nan=False)]
NonNegOrVec = or_list(NonNeg)


def _torque_limit(value: Any) -> Any:
    if isinstance(value, str):
        if value not in LIMIT_WORDS:
            fail(
                (),
                f" = {value!r} unknown{did_you_mean(value, LIMIT_WORDS)}; valid choices: "
                "'none', 'urdf', a number or one number per joint [N m]",
            )
        return value
    _number_or_numbers(value)
    for x in value if isinstance(value, list) else [value]:
        if not (x > 0 and math.isfinite(x)):
            fail((), f" = {value}: every limit must be a finite number > 0 [N m]")
    return value


Fraction = Annotated[Num, interval("[0, 1)", lambda x: 0 <= x < 1)]
Sigma = Annotated[Num, interval("(0, 1]", lambda x: 0 < x <= 1)]
