"""The numpydoc entries the scenario layer's docstrings share (:mod:`ffsm_pin._docstrings`); a
docstring names them ``%(name)s``."""

from __future__ import annotations

from .._docstrings import doc_entries

SCENARIO_DOC = doc_entries(
    t_order="""
        t : float or complex
            Time [s].
        order : int
            Order of the derivative (0: the value).""",
)
