"""Markdown of the report: tables, numbers, and the short labels of controllers."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from ...control.registry import controller_label

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "controller_labels", "f", "interval", "is_number", "kept_text", "label", "relabel",
    "short_label", "table", "value",
]  # fmt: skip

Column = tuple[str, str | None, str | None]  # (header, row key, format; None: value())


def table(
    rows: Iterable[Mapping[str, Any]],
    columns: list[Column],
    extra: Mapping[str, Callable[[Mapping[str, Any]], str]] | None = None,
) -> list[str]:
    """A markdown table: one column per ``(header, key, format)``; ``extra`` computes the
    cells of the headers it names.

    Parameters
    ----------
    rows : iterable of mapping
        The rows.
    columns : list of Column
        (header, key, format) per column.
    extra : mapping or None
        Header -> function of a row giving its cell.

    Returns
    -------
    list of str
        The table's lines.
    """
    extra = extra or {}
    head = [name for name, _, _ in columns]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = []
        for name, key, fmt in columns:
            if name in extra:
                cells.append(extra[name](r))
            elif fmt is None:
                cells.append(value(r[key]))  # type: ignore[index]
            else:
                cells.append(f(r[key], fmt))  # type: ignore[index]
        out.append("| " + " | ".join(cells) + " |")
    return out


def label(r: Mapping[str, Any], cols) -> str:
    """A grid point's values in words ("all" without axes).

    Parameters
    ----------
    r : mapping
        A row.
    cols : sequence of str
        The grid's columns.

    Returns
    -------
    str
        The words.
    """
    return ", ".join(value(r[c]) for c in cols) or "all"


def value(v: Any) -> str:
    """A cell of a value as it is (numbers in their shortest form)."""
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list):
        return "[" + ", ".join(value(x) for x in v) + "]"
    return str(v)


def f(x: Any, fmt: str) -> str:
    """``fmt`` of ``x``; "-" for null and non-finite numbers.

    Parameters
    ----------
    x : object
        The value.
    fmt : str
        A ``str.format`` template.

    Returns
    -------
    str
        The text.
    """
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return fmt.format(x)


def interval(lo: Any, hi: Any, fmt: str = "{:.0%}") -> str:
    """The cell "lo - hi".

    Parameters
    ----------
    lo, hi : float or None
        The bounds.
    fmt : str
        A ``str.format`` template.

    Returns
    -------
    str
        The cell.
    """
    return f"{f(lo, fmt)} - {f(hi, fmt)}"


def kept_text(ok: Any) -> str:
    """A funnel kept or LEFT ("-" when unknown)."""
    return "-" if ok is None else "kept" if ok else "LEFT"


def is_number(x: Any) -> bool:
    """A number, not a bool."""
    return isinstance(x, (int, float)) and not isinstance(x, bool)


# ------------------------------------------------------------------------------ labels
def short_label(kind: str, params_label: Any = None) -> str:
    """What the report calls a controller: ``label`` of its ``[controller.params]``, else the
    class name of a user's ``"file.py:Class"`` or ``"package.module:Class"``, else the type.

    Parameters
    ----------
    kind : str
        The controller type.
    params_label : object
        Its ``[controller.params] label``, if any.

    Returns
    -------
    str
        The label.
    """
    if isinstance(params_label, str) and params_label.strip():
        return params_label.strip()
    return controller_label(kind)


def controller_labels(kinds: Mapping[str, str | None]) -> dict[str, str]:
    """Short labels of controller types, ``{type: a scenario TOML of it (or None)}``; two user
    types of the same class name keep their file or module name in front."""
    out = {}
    for kind, toml in kinds.items():
        params: Any = {}
        if toml:
            try:
                params = tomllib.loads(toml).get("controller", {}).get("params", {})
            except tomllib.TOMLDecodeError:
                params = {}
        out[kind] = short_label(kind, params.get("label") if isinstance(params, dict) else None)
    seen: dict[str, list[str]] = {}
    for kind, name in out.items():
        seen.setdefault(name, []).append(kind)
    for name, same in seen.items():
        if len(same) > 1:
            for kind in same:
                if ":" in kind:
                    where = kind.rpartition(":")[0]
                    out[kind] = f"{Path(where).name if where.endswith('.py') else where}:{name}"
    return out


def relabel(rows: list[dict[str, Any]], labels: Mapping[str, str], keys: Iterable[str]) -> None:
    """Replace controller types by their labels in the columns ``keys`` of ``rows``.

    Parameters
    ----------
    rows : list of dict
        Changed in place.
    labels : mapping of str to str
        Controller type -> its label.
    keys : iterable of str
        The columns.
    """
    keys = list(keys)
    for r in rows:
        for k in keys:
            if isinstance(r.get(k), str):
                r[k] = labels.get(r[k], r[k])
