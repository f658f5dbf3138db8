"""Docstring templates by substitution, as scipy's ``doccer`` and matplotlib's ``_docstring``
do: numpydoc entries that several docstrings share (the same parameter, a whole
``Parameters`` section) are written once, in a mapping, and a docstring names them on a line
of their own as ``%(name)s``.

The substitution happens once, when the module is imported, so :func:`inspect.getdoc`,
Sphinx (napoleon) and numpydoc read the finished docstring. An entry's text is dedented and
every line of it is indented like the placeholder, so an entry serves a function and a method
alike. Decorate below ``@njit``: the compiled function keeps its Python function's docstring.

Example (``ffsm_pin/model/interface.py``): ``_DOC = doc_entries(q_m="q_m : ndarray ...",
params_q_m=("q_m",))`` lists the entries; a class or function decorated ``@fill_doc(_DOC)``
writes ``%(q_m)s`` on the line where the ``q_m`` entry stands in its ``Parameters`` section,
or ``%(params_q_m)s`` where the whole section stands. docs/api.md has the rules.
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Callable, Mapping
from typing import TypeVar

F = TypeVar("F", bound=Callable)

_PLACEHOLDER = re.compile(r"^(?P<indent>[ \t]*)%\((?P<name>\w+)\)s[ \t]*$", re.MULTILINE)


def doc_entries(**entries: str | tuple[str, ...]) -> dict[str, str]:
    """The shared entries of a module, dedented and stripped of surrounding blank lines.

    Parameters
    ----------
    **entries : str or tuple of str
        Name -> the numpydoc text (any indentation; it may name an entry given before it as
        ``%(name)s``), or a tuple of names of entries given before it: a whole
        ``Parameters`` section of those entries, in that order.

    Returns
    -------
    dict of str to str
        The entries, ready for :func:`fill_doc`.
    """
    out: dict[str, str] = {}
    for name, text in entries.items():
        if isinstance(text, tuple):
            out[name] = "\n".join(["Parameters", "----------", *(out[e] for e in text)])
        else:
            out[name] = substitute(textwrap.dedent(text).strip("\n"), out)
    return out


def substitute(doc: str, entries: Mapping[str, str]) -> str:
    """``doc`` with each placeholder line ``%(name)s`` replaced by the entry, every line of it
    indented like the placeholder.

    Parameters
    ----------
    doc : str
        A docstring (or an entry).
    entries : mapping of str to str
        The entries (:func:`doc_entries`).

    Returns
    -------
    str
        The docstring with its placeholders filled.

    Raises
    ------
    KeyError
        For a placeholder no entry fills (a typo shows at import).
    """

    def fill(match: re.Match) -> str:
        indent = match["indent"]
        lines = entries[match["name"]].splitlines()
        return "\n".join(indent + line if line else line for line in lines)

    return _PLACEHOLDER.sub(fill, doc)


def fill_doc(entries: Mapping[str, str]) -> Callable[[F], F]:
    """A decorator that fills the placeholders of a function's docstring, or of a class's and
    of the functions it defines (its methods, static and class methods).

    Parameters
    ----------
    entries : mapping of str to str
        The entries (:func:`doc_entries`).

    Returns
    -------
    callable
        The decorator; it returns the object it is given, its ``__doc__`` filled.
    """

    def decorate(obj: F) -> F:
        members = vars(obj).values() if isinstance(obj, type) else ()
        for target in (obj, *members):
            target = getattr(target, "__func__", target)  # static and class methods
            if callable(target) and target.__doc__:
                target.__doc__ = substitute(target.__doc__, entries)
        return obj

    return decorate
