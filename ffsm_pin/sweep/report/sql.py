"""The report's DuckDB queries over results.parquet, as SQL text that report.md prints.

``{cols}`` placeholders: ``{cols_sel}`` the varied keys as quoted identifiers followed by a
comma, ``{group}``/``{order}`` GROUP BY / ORDER BY them, ``{path}`` the file, ``{by}`` the
columns a per-controller table is also grouped by (the scenario), ``{extra}`` the columns a
results.parquet of this version has and an older one lacks (:func:`present`).

A case *keeps its funnels* when it completed the whole horizon with both funnels kept
(:data:`KEPT`); rows with ``status = 'error'`` are not runs and are left out of the rates.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import duckdb

from ..._docstrings import doc_entries, fill_doc
from ..stats import Z95

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    path="""
        path : Path
            ``results.parquet``.""",
    returns_str="""
        Returns
        -------
        str
            The query.""",
    by="""
        by : tuple of str
            Columns grouped by besides the controller.""",
    params_path_by=("path", "by"),
)

__all__ = [
    "CAUSES_SQL", "CONTROLLER_KEY", "CONTROLLER_SQL", "FAILED_SQL", "KEPT", "KEPT_Z",
    "N_WORST", "POINTS_SQL", "RATE_SQL", "RUNS_SQL", "SPREAD_SQL", "WORST_SQL",
    "connection", "controller_table", "present", "query", "sql",
]  # fmt: skip

N_WORST = 10
KEPT = "(status = 'completed' AND funnel_ok_b AND funnel_ok_z)"
KEPT_Z = "(status = 'completed' AND funnel_ok_z)"
CONTROLLER_KEY = "controller.type"


def _wilson(rate: str, n: str, name: str) -> str:
    """SQL for the 95 % Wilson score interval of the column ``rate`` (a share of ``n`` runs),
    as ``name_lo`` and ``name_hi``."""
    half = f"{Z95} * sqrt({rate} * (1 - {rate}) / {n} + {Z95}^2 / (4 * {n} * {n}))"
    centre, scale = f"{rate} + {Z95}^2 / (2 * {n})", f"(1 + {Z95}^2 / {n})"
    return (
        f"({centre} - {half})\n    / {scale} AS {name}_lo,\n"
        f"  ({centre} + {half})\n    / {scale} AS {name}_hi"
    )


RATE_SQL = f"""\
WITH counts AS (
  SELECT {{cols_sel}}
         count(*) FILTER (WHERE status <> 'error') AS n,
         count(*) FILTER (WHERE {KEPT}) AS kept,
         count(*) FILTER (WHERE status = 'stopped') AS stopped,
         count(*) FILTER (WHERE status = 'error') AS errors
  FROM read_parquet('{{path}}')
  WHERE NOT nominal
  {{group}}
), rates AS (
  SELECT *, CASE WHEN n > 0 THEN kept / n END AS rate FROM counts
)
SELECT *,  -- Wilson score interval, z = {Z95:.4f}
  {_wilson("rate", "n", "rate")}
FROM rates
{{order}}"""

SPREAD_SQL = """\
SELECT {cols_sel}
  median(max_abs_u) AS u_median,
  quantile_cont(max_abs_u, 0.95) AS u_p95,
  max(max_abs_u) AS u_max,{extra}
  count(settle_time_z) AS settled_z,
  median(settle_time_z) AS settle_z_median,
  max(settle_time_z) AS settle_z_max,
  median(settle_time_b) AS settle_b_median,
  min(min_sigma) AS sigma_min,
  median(min_sigma) AS sigma_median
FROM read_parquet('{path}')
WHERE NOT nominal AND status <> 'error'
{group}
{order}"""
SPREAD_EXTRA = {
    "max_joint_torque": "median(max_joint_torque) AS u_joint_median,\n"
    "  max(max_joint_torque) AS u_joint_max",
    "min_sigma_gjm": "min(min_sigma_gjm) AS gjm_min,\n  median(min_sigma_gjm) AS gjm_median",
}

WORST_SQL = f"""\
SELECT "case", {{cols_sel}}estimates_seed, status, funnel_ok_b, funnel_ok_z, max_abs_u,
       min_sigma, stop_time, stop_reason, scenario_toml
FROM read_parquet('{{path}}')
WHERE NOT nominal AND status <> 'error'
ORDER BY {KEPT} ASC, max_abs_u DESC NULLS FIRST
LIMIT {N_WORST}"""

CAUSES_SQL = """\
SELECT {cols_sel}
  CASE
    WHEN stop_reason ILIKE '%left its funnel%' THEN 'funnel left'
    WHEN stop_reason ILIKE '%singular%' THEN 'arm or filter singular'
    WHEN stop_reason ILIKE '%blow-up%' OR stop_reason ILIKE '%non-finite%'
      THEN 'numerical blow-up'
    WHEN stop_reason ILIKE '%positive definite%' OR stop_reason ILIKE '%collapsed%'
      THEN 'estimate degenerate'
    ELSE 'other'
  END AS cause,
  count(*) AS runs,
  min(stop_time) AS first_stop,
  median(stop_time) AS median_stop
FROM read_parquet('{path}')
WHERE NOT nominal AND status = 'stopped'
GROUP BY ALL
ORDER BY ALL"""

CONTROLLER_SQL = f"""\
WITH runs AS (
  SELECT * FROM read_parquet('{{path}}') WHERE NOT nominal AND status <> 'error'
), per AS (
  SELECT {{by}}"{CONTROLLER_KEY}" AS controller,
         count(*) AS n,
         count(*) FILTER (WHERE {KEPT}) AS kept,
         count(*) FILTER (WHERE {KEPT_Z}) AS kept_z,
         median(rms_err_z_late) AS rms_err_z_late,
         median(max_abs_u) AS max_abs_u,{{extra}}
         median(saturation_fraction) AS saturation_fraction,
         median(control_effort) AS control_effort,
         median(max_base_excursion) AS max_base_excursion,
         count(settle_time_z) AS settled_z,
         median(settle_time_z) AS settle_time_z
  FROM runs
  GROUP BY ALL
), rates AS (
  SELECT *, kept / n AS rate, kept_z / n AS rate_z FROM per
)
SELECT *,  -- Wilson score intervals, z = {Z95:.4f}
  {_wilson("rate", "n", "rate")},
  {_wilson("rate_z", "n", "rate_z")}
FROM rates
ORDER BY {{by}}controller"""
CONTROLLER_EXTRA = {
    "max_joint_torque": "median(max_joint_torque) AS max_joint_torque",
    "min_sigma_gjm": "median(min_sigma_gjm) AS min_sigma_gjm",
    "min_sigma_of": "median(min_sigma) AS min_sigma,\n"
    "         string_agg(DISTINCT min_sigma_of, ', ') AS min_sigma_of",
}

POINTS_SQL = """\
SELECT {cols_sel} max_abs_u, settle_time_z, min_sigma, damping_threshold{extra}
FROM read_parquet('{path}')
WHERE NOT nominal AND status <> 'error'
{order}"""
POINTS_EXTRA = {"max_joint_torque": "max_joint_torque", "min_sigma_gjm": "min_sigma_gjm"}

# "Why runs failed": the runs that did not keep both funnels, by how they ended, the funnel
# and component first left, and when
FAILED_SQL = f"""\
SELECT {{by}}controller,
  CASE WHEN status = 'stopped' THEN 'stopped: ' || coalesce(stop_cause, 'other')
       ELSE 'completed' END AS outcome,
  first_violation_funnel AS funnel,
  first_violation_component AS component,
  count(*) AS runs,
  min(coalesce(first_violation_t, stop_time)) AS first_t,
  median(coalesce(first_violation_t, stop_time)) AS median_t
FROM read_parquet('{{path}}')
WHERE NOT nominal AND status <> 'error' AND NOT {KEPT}
GROUP BY ALL
ORDER BY ALL"""

# every run, for the paired comparison and the choice of the runs the overlays draw
RUNS_SQL = f"""\
SELECT "case", {{cols_sel}}"repeat", estimates_seed, controller, status,
       {KEPT} AS kept, first_violation_t, stop_time, rms_err_z_late{{extra}}
FROM read_parquet('{{path}}')
WHERE NOT nominal AND status <> 'error'
ORDER BY 1"""
RUNS_EXTRA = {
    "first_violation_funnel": "first_violation_funnel",
    "first_violation_component": "first_violation_component",
    "joint_torque_limits": "joint_torque_limits",
}


@fill_doc(_DOC)
def sql(template: str, path: Path, cols: list[str] | tuple[str, ...] = (), **more: str) -> str:
    """``template`` with the placeholders filled (module docstring); ``more``: the others.

    Parameters
    ----------
    template : str
        The query with placeholders.
    %(path)s
    cols : sequence of str
        The grid's columns.

    %(returns_str)s
    """
    names = [ident(c) for c in cols]
    text = template.format(
        path=quoted(path),
        cols_sel="".join(f"{c}, " for c in names),
        group=f"GROUP BY {', '.join(names)}" if cols else "",
        order=f"ORDER BY {', '.join(names)}" if cols else "",
        **{"extra": "", "by": "", **more},
    )
    return "\n".join(line.rstrip() for line in text.splitlines() if line.strip())


def extra(specs: dict[str, str], have: set[str], indent: str = "\n  ", comma_first=False) -> str:
    """The ``{extra}`` text: the expressions of ``specs`` whose column the file has.

    Parameters
    ----------
    specs : dict of str to str
        Column -> expression.
    have : set of str
        The file's columns.
    indent : str
        Put before each expression.
    comma_first : bool
        Each expression after a comma, on one line.

    Returns
    -------
    str
        The text.
    """
    parts = [expr for column, expr in specs.items() if column in have]
    if not parts:
        return ""
    if comma_first:
        return "".join(f", {p}" for p in parts)
    return "".join(f"{indent}{p}," for p in parts)


def quoted(path: Path) -> str:
    """``path`` for a single-quoted SQL string."""
    return str(path).replace("'", "''")


def ident(name: str) -> str:
    """A quoted SQL identifier."""
    return '"' + name.replace('"', '""') + '"'


def by_sel(by: tuple[str, ...]) -> str:
    """``{by}``: the columns as a select list prefix."""
    return "".join(f"{ident(c)}, " for c in by)


_CONNECTION: dict[int, duckdb.DuckDBPyConnection] = {}  # process id -> its in-memory DuckDB


def connection() -> duckdb.DuckDBPyConnection:
    """The in-memory DuckDB of the calling process, made on its first call: opening one costs
    some 13 ms, a report runs a dozen queries. It holds no table and caches no file between queries
    (DuckDB's external file cache and Parquet metadata cache off), so every query reads the
    files as they are then, as a fresh connection would. A forked process makes its own.

    Returns
    -------
    duckdb.DuckDBPyConnection
        The connection (:func:`query` takes a cursor of it per query).
    """
    con = _CONNECTION.get(os.getpid())
    if con is None:
        _CONNECTION.clear()  # a parent's, inherited through fork: not ours to use or close
        con = duckdb.connect()
        con.execute("SET enable_external_file_cache = false")
        con.execute("SET parquet_metadata_cache = false")
        _CONNECTION[os.getpid()] = con
    return con


def query(text: str) -> list[dict[str, Any]]:
    """Run SQL on a cursor of this process's in-memory DuckDB (:func:`connection`); rows as
    dicts.

    Parameters
    ----------
    text : str
        The SQL.

    Returns
    -------
    list of dict
        The rows, ``{column: value}``.
    """
    cur = connection().cursor()
    try:
        cur.execute(text)
        names = [d[0] for d in cur.description]
        return [dict(zip(names, row, strict=True)) for row in cur.fetchall()]
    finally:
        cur.close()


def present(path: Path) -> set[str]:
    """The columns of the Parquet file at ``path``."""
    rows = query(f"DESCRIBE SELECT * FROM read_parquet('{quoted(path)}')")
    return {r["column_name"] for r in rows}


@fill_doc(_DOC)
def controller_sql(path: Path, by: tuple[str, ...] = (), have: set[str] | None = None) -> str:
    """:data:`CONTROLLER_SQL` for the file at ``path`` (``have``: its columns).

    %(params_path_by)s
    have : set of str or None
        The file's columns; None: read from the file.

    %(returns_str)s
    """
    have = present(path) if have is None else have
    ext = extra(CONTROLLER_EXTRA, have, indent="\n         ")
    return CONTROLLER_SQL.format(path=quoted(path), by=by_sel(by), extra=ext)


@fill_doc(_DOC)
def controller_table(path: Path, by: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """The per-controller rows of :data:`CONTROLLER_SQL` for ``results.parquet`` at ``path``,
    per value of the columns ``by`` too (``("scenario",)``: per scenario and controller).

    %(params_path_by)s

    Returns
    -------
    list of dict
        The rows.
    """
    return query(controller_sql(path, by))
