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
)
