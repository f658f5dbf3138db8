"""report.md of a campaign: DuckDB SQL over results.parquet, scipy statistics, matplotlib
figures (docs/campaigns.md, "The report").

* :mod:`.sql`: the queries (:data:`RATE_SQL`, :data:`SPREAD_SQL`, :data:`WORST_SQL`,
  :data:`CAUSES_SQL`, :data:`CONTROLLER_SQL`, :data:`FAILED_SQL`, ...); report.md prints them,
  so a reader can run the same ones in ``duckdb``;
* :mod:`ffsm_pin.sweep.stats`: Wilson and Clopper-Pearson intervals, the exact McNemar test,
  run counts;
* :mod:`.sections`: "Why runs failed", "Paired comparison", "How many runs";
* :mod:`.figures`: the rate and distribution figures, the median and worst runs
  (``fig_overlay_*.png``);
* :mod:`.text`: markdown tables and the short labels of controllers;
* :mod:`.write`: :func:`write_report`, the sections in order.

A case *keeps its funnels* when it completed the whole horizon with both funnels kept
(``status = 'completed' AND funnel_ok_b AND funnel_ok_z``); rows with ``status = 'error'`` are
not runs and are left out of the rates (and listed).
"""

from __future__ import annotations

from ..stats import Z95
from .figures import figures
from .sql import (
    CAUSES_SQL,
    CONTROLLER_SQL,
    FAILED_SQL,
    RATE_SQL,
    SPREAD_SQL,
    WORST_SQL,
    controller_table,
    query,
    sql,
)
from .write import write_report

__all__ = [
    "CAUSES_SQL", "CONTROLLER_SQL", "FAILED_SQL", "RATE_SQL", "SPREAD_SQL", "WORST_SQL", "Z95",
    "controller_table", "figures", "query", "sql", "write_report",
]  # fmt: skip
