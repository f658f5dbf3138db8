"""Campaigns: many variations of a scenario on a Dask cluster (``python -m ffsm_pin.sweep``).

:mod:`~ffsm_pin.sweep.campaign` (campaign files), :mod:`~ffsm_pin.sweep.cases` (their cases),
:mod:`~ffsm_pin.sweep.check` (the cases through the run's set-up before anything runs),
:mod:`~ffsm_pin.sweep.seeds` (one random stream per case), :mod:`~ffsm_pin.sweep.engine`
(Dask), :mod:`~ffsm_pin.sweep.table` (results.parquet), :mod:`~ffsm_pin.sweep.explain` and
:mod:`~ffsm_pin.sweep.signals_file` (what a case adds to its row, signals.parquet),
:mod:`~ffsm_pin.sweep.report` (DuckDB SQL, figures, report.md), :mod:`~ffsm_pin.sweep.stats`
(intervals, tests, run counts), :mod:`~ffsm_pin.sweep.auto_repeat` (``repeat = "auto"``) and
:mod:`~ffsm_pin.sweep.cli`. See docs/campaigns.md.
"""
