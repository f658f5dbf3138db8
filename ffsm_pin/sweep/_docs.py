"""The numpydoc entries the sweep layer's docstrings share (:mod:`ffsm_pin._docstrings`); a
docstring names them ``%(name)s``."""

from __future__ import annotations

from .._docstrings import doc_entries

SWEEP_DOC = doc_entries(
    campaign_cases="""
        campaign : Campaign
            The campaign.
        cases : list of Case
            Its cases.""",
    case_rows="""
        setup : Setup
            The case's setup.
        signals : mapping of str to ndarray
            The run's signals (``q``, ``v``).
        rows : ndarray of int
            The rows evaluated.""",
    params_case_rows=("case_rows",),
)
