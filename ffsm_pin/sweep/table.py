"""results.parquet: one row per case, rewritten atomically (temp file + rename) as rows arrive.

A reader (or an interrupted campaign) always sees a complete Parquet file holding every row
finished so far. Rows are kept by ``case_hash``: adding the row of a hash that is already there
replaces it, so a case never has two rows.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from .campaign import Case

__all__ = ["HEAD", "SUMMARY_TYPES", "ResultsTable", "case_columns"]

# Columns every row has, before the varied keys.
HEAD = {
    "case": pa.int64(),
    "case_hash": pa.string(),
    "nominal": pa.bool_(),
    "grid_point": pa.int64(),
    "repeat": pa.int64(),
}
# After the varied keys.
MIDDLE = {"estimates_seed": pa.int64(), "status": pa.string(), "error": pa.string()}
# Scalars of summary.json (ffsm_pin.sim.result.RunResult.summary); others are inferred.
SUMMARY_TYPES = {
    "scheme": pa.string(),
    "robot": pa.string(),
    "scenario": pa.string(),
    "description": pa.string(),
    "dt": pa.float64(),
    "duration": pa.float64(),
    "steps": pa.int64(),
    "simulated_time": pa.float64(),
    "wall_time_s": pa.float64(),
    "steps_per_s": pa.float64(),
    "funnel_ok_b": pa.bool_(),
    "funnel_ok_z": pa.bool_(),
    "first_violation_t": pa.float64(),
    "max_abs_u": pa.float64(),
    "drift_P": pa.float64(),
    "drift_L": pa.float64(),
    "settle_time_b": pa.float64(),
    "settle_time_z": pa.float64(),
    "completed": pa.bool_(),
    "stop_reason": pa.string(),
    "stop_time": pa.float64(),
    "min_sigma": pa.float64(),
    "damping_threshold": pa.float64(),
    "damped_fraction": pa.float64(),
    "max_abs_F_r": pa.float64(),
    "final_theta_z_error": pa.float64(),
    "final_theta_d_error": pa.float64(),
    "case_wall_s": pa.float64(),  # the whole case on its worker (ffsm_pin.sweep.engine.run_case)
    "case_cpu_s": pa.float64(),
}
TAIL = {"scenario_toml": pa.string()}


def case_columns(case: Case) -> dict[str, Any]:
    """The columns of a row that come from the case itself (not from its run)."""
    return {
        "case": case.index,
        "case_hash": case.case_hash,
        "nominal": case.nominal,
        "grid_point": case.point_index,
        "repeat": case.repeat,
        **case.values,
        "estimates_seed": case.estimates_seed,
    }


class ResultsTable:
    """The rows of a campaign, by case hash, and their Parquet file."""

    def __init__(self, path: Path, key_columns: Iterable[str]):
        self.path = Path(path)
        self.key_columns = list(key_columns)
        self.rows: dict[str, dict[str, Any]] = {}

    def read(self) -> list[dict[str, Any]]:
        """The rows of an existing file ([] if there is none)."""
        if not self.path.is_file():
            return []
        return pq.read_table(self.path).to_pylist()

    def add(self, case: Case, outcome: Mapping[str, Any], write: bool = True) -> dict[str, Any]:
        """Record one case's outcome (replacing a row of the same hash) and rewrite the file."""
        row = {**case_columns(case), **{k: None for k in SUMMARY_TYPES}, **outcome}
        row["scenario_toml"] = case.scenario_toml
        self.rows[case.case_hash] = row
        if write:
            self.write()
        return row

    def keep(self, row: Mapping[str, Any], case: Case) -> None:
        """Keep a finished row of an earlier run of the campaign (renumbered as ``case``)."""
        self.rows[case.case_hash] = {**dict(row), **case_columns(case)}

    def table(self) -> pa.Table:
        rows = sorted(self.rows.values(), key=lambda r: r["case"])
        known = {**HEAD, **{k: None for k in self.key_columns}, **MIDDLE, **SUMMARY_TYPES}
        names = list(known)
        for row in rows:
            names += [k for k in row if k not in known and k not in TAIL and k not in names]
        names += list(TAIL)
        arrays, fields = [], []
        for name in names:
            values = [row.get(name) for row in rows]
            typ = {**known, **TAIL}.get(name) or _infer(values)
            arrays.append(pa.array(values, type=typ))
            fields.append(pa.field(name, typ))
        return pa.Table.from_arrays(arrays, schema=pa.schema(fields))

    def write(self) -> None:
        """Write the file atomically: a temporary file in the same folder, then a rename."""
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        try:
            pq.write_table(self.table(), tmp)
            os.replace(tmp, self.path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise


def _infer(values: list[Any]) -> pa.DataType:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.int64() if all(isinstance(v, int) for v in present) else pa.float64()
    if not present:
        return pa.null()
    return pa.array(present).type
