"""Campaigns: many variations of a scenario on a Dask cluster (``python -m ffsm_pin.sweep``).

:mod:`~ffsm_pin.sweep.campaign` (campaign files and their cases), :mod:`~ffsm_pin.sweep.seeds`
(one random stream per case), :mod:`~ffsm_pin.sweep.engine` (Dask), :mod:`~ffsm_pin.sweep.table`
(results.parquet), :mod:`~ffsm_pin.sweep.report` (DuckDB SQL, figures, report.md) and
:mod:`~ffsm_pin.sweep.cli`. See docs/campaigns.md.
"""
