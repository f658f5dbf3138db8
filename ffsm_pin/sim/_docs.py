"""The numpydoc entries the simulation layer's docstrings share (:mod:`ffsm_pin._docstrings`); a
docstring names them ``%(name)s``."""

from __future__ import annotations

from .._docstrings import doc_entries

SIM_DOC = doc_entries(
    model_data="""
        model : pin.Model
            The Pinocchio model.
        data : pin.Data
            Its data.""",
    target_motion="""
        target : Target
            The body.
        state : TargetState
            Its state at t = 0.""",
)
