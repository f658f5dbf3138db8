"""Docstring templates (ffsm_pin/_docstrings.py, issue 36): entries written once are filled in
at import with the placeholder's indentation; the planar and spatial models take the
ReducedModel protocol's docstrings; no placeholder is left unfilled anywhere in the package."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import pytest
from numba import njit

import ffsm_pin
from ffsm_pin._docstrings import doc_entries, fill_doc, substitute
from ffsm_pin.model.interface import ReducedModel
from ffsm_pin.model.planar import BarycentricModel
from ffsm_pin.model.spatial import SpatialBarycentricModel

ENTRIES = doc_entries(
    a="""
            a : int
                First.""",
    b="""
        %(a)s
        b : float
            Second.""",
    params_a=("a",),
)


def test_an_entry_takes_the_placeholders_indentation():
    doc = "Summary.\n\n        Parameters\n        ----------\n        %(b)s\n        c : str\n"
    assert substitute(doc, ENTRIES) == (
        "Summary.\n\n        Parameters\n        ----------\n        a : int\n            First."
        "\n        b : float\n            Second.\n        c : str\n"
    )


def test_a_tuple_is_a_whole_parameters_section():
    assert ENTRIES["params_a"] == "Parameters\n----------\na : int\n    First."


def test_a_placeholder_inside_a_line_is_text():
    doc = "Writes ``%(a)s`` literally.\n"
    assert substitute(doc, ENTRIES) == doc


def test_an_unknown_placeholder_fails_at_import():
    with pytest.raises(KeyError):
        substitute("    %(nope)s\n", ENTRIES)


def test_a_class_and_its_methods_are_filled():
    @fill_doc(ENTRIES)
    class Thing:
        """%(params_a)s"""

        def method(self, a):
            """M.

            %(params_a)s
            """

        @staticmethod
        def static(a):
            """%(a)s"""

    assert Thing.__doc__ == "Parameters\n----------\na : int\n    First."
    assert "            a : int\n                First." in Thing.method.__doc__
    assert Thing.static.__doc__ == "a : int\n    First."


def test_a_compiled_function_keeps_the_filled_docstring():
    @njit
    @fill_doc(ENTRIES)
    def twice(a):
        """T.

        %(a)s
        """
        return 2 * a

    assert twice(3) == 6
    assert "a : int" in twice.__doc__ and "a : int" in twice.py_func.__doc__


@pytest.mark.parametrize("model", [BarycentricModel, SpatialBarycentricModel])
def test_the_models_take_the_protocols_docstrings(model):
    names = [n for n, v in vars(ReducedModel).items() if inspect.isfunction(v)]
    names = [n for n in names if not n.startswith("_")]
    assert len(names) >= 15 and ReducedModel in model.__mro__
    for name in names:
        own = getattr(model, name)
        if own.__doc__ is None:  # inherits: the protocol's text, filled
            assert inspect.getdoc(own) == inspect.getdoc(getattr(ReducedModel, name)), name
            assert "Parameters" in inspect.getdoc(own) or name == "kernel_constants"


def _docstrings():
    for info in pkgutil.walk_packages(ffsm_pin.__path__, ffsm_pin.__name__ + "."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if getattr(obj, "__module__", None) != module.__name__:
                continue
            yield info.name, obj
            if inspect.isclass(obj):
                yield from ((info.name, m) for m in vars(obj).values())


def test_no_placeholder_is_left_unfilled():
    placeholder = re.compile(r"^\s*%\(\w+\)s\s*$", re.M)
    left = []
    for module, obj in _docstrings():
        obj = getattr(obj, "__func__", obj)
        doc = getattr(getattr(obj, "py_func", obj), "__doc__", None)
        if isinstance(doc, str) and placeholder.search(doc):
            left.append(f"{module}.{getattr(obj, '__qualname__', obj)}")
    assert not left, left
