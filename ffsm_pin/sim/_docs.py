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
    u_m_held="""
        u_m : ndarray, shape (n,)
            Joint torques [N m], held.""",
    dt_substeps="""
        dt : float
            Control step [s].
        substeps : int
            Plant steps per control step.""",
    setup="""
        setup : Setup
            The prepared run.""",
    params_setup=("setup",),
)
