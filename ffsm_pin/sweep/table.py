"""results.parquet: one row per case, rewritten atomically (temp file + rename) as rows arrive.

A reader (or an interrupted campaign) always sees a complete Parquet file holding the rows
finished so far. Rows are kept by ``case_hash``: adding the row of a hash that is already there
replaces it, so a case never has two rows.

A rewrite costs time proportional to the rows already there, so rewriting after every row is
quadratic in the campaign's size. The campaign therefore rewrites when
:meth:`ResultsTable.write_due` says so: at least ``min_interval_s`` after the previous write and
no more often than keeps the writes at ``write_share`` of the wall time (1 % by default), plus a
final :meth:`ResultsTable.flush` when the loop ends or is interrupted. A campaign killed
outright (SIGKILL, power loss) loses at most the rows of that last interval, which a resume runs
again (docs/campaigns.md).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from ..sim.files import replaced_file
from .cases import Case
from .explain import SIGNALS
from .signals_file import SignalsFile

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
    "first_violation_funnel": pa.string(),  # "b" | "z"
    "first_violation_component": pa.int64(),
    "max_abs_u": pa.float64(),
    "max_torque_norm": pa.float64(),  # = max_abs_u: max over time of the norm of u_m
    "max_joint_torque": pa.float64(),  # max over time and joints of |u_m[i]|
    "max_abs_u_cmd": pa.float64(),
    "funnel_relaxed_time": pa.float64(),  # [s] saturation = "auxiliary" (None: not on)
    "first_relaxed_t": pa.float64(),
    "last_relaxed_t": pa.float64(),
    "saturation_fraction": pa.float64(),
    "saturation_per_joint": pa.list_(pa.float64()),
    "joint_torque_limits": pa.list_(pa.float64()),  # [N m], null: none
    "controller": pa.string(),
    "drift_P": pa.float64(),
    "drift_L": pa.float64(),
    "settle_time_b": pa.float64(),
    "settle_time_z": pa.float64(),
    "completed": pa.bool_(),
    "stop_reason": pa.string(),
    "stop_time": pa.float64(),
    "stop_cause": pa.string(),
    "stop_funnel": pa.string(),
    "min_sigma": pa.float64(),
    "min_sigma_of": pa.string(),  # what min_sigma is the sigma_min of (the controller's own)
    "min_sigma_gjm": pa.float64(),  # the true generalized Jacobian's, for every controller
    "damping_threshold": pa.float64(),
    "damped_fraction": pa.float64(),
    "max_abs_F_r": pa.float64(),
    "rms_err_z_late": pa.float64(),
    "control_effort": pa.float64(),
    "max_base_excursion": pa.float64(),
    "final_theta_z_error": pa.float64(),
    "final_theta_d_error": pa.float64(),
    "case_wall_s": pa.float64(),  # the whole case on its worker (ffsm_pin.sweep.engine.run_case)
    "case_cpu_s": pa.float64(),
    "blas": pa.string(),  # the worker's BLAS libraries and kernels (ffsm_pin/_numerics.py)
    "versions": pa.string(),
}
TAIL = {"scenario_toml": pa.string()}
# Columns of some runs only (a scenario with [capture] or wheels, docs/capture.md), typed
# when present.
OPTIONAL_TYPES = {
    "captured": pa.bool_(),
    "capture_time": pa.float64(),  # [s]
    "impact_impulse": pa.list_(pa.float64()),  # [N s] x 3, [N m s] x 3
    "relative_speed_at_capture": pa.float64(),  # [m/s]
    "impact_energy_lost": pa.float64(),  # [J]
    "wheel_saturation_fraction": pa.float64(),  # [robot.satellite.wheels]
    "detumble_time": pa.float64(),  # [s], [capture]
}


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
    """The rows of a campaign, by case hash, and their Parquet file; the cases' decimated
    signals (an outcome's ``"signals"`` entry) go to ``signals.parquet`` beside it
    (:class:`~ffsm_pin.sweep.signals_file.SignalsFile`), written with it.

    Parameters
    ----------
    path : Path
        The Parquet file.
    key_columns : iterable of str
        The case columns (grid keys), placed after the head columns.
    min_interval_s : float
        Least time between two rewrites [s].
    write_share : float
        Largest share of wall time spent rewriting.
    """

    def __init__(
        self,
        path: Path,
        key_columns: Iterable[str],
        *,
        min_interval_s: float = 1.0,
        write_share: float = 0.01,
    ):
        self.path = Path(path)
        self.signals = SignalsFile(self.path.with_name("signals.parquet"))
        self.key_columns = list(key_columns)
        self.rows: dict[str, dict[str, Any]] = {}
        self.min_interval_s = min_interval_s  # [s] between two rewrites (write_due)
        self.write_share = write_share  # largest share of wall time spent rewriting
        self.dirty = False  # rows added since the last write
        self.writes = 0  # rewrites so far
        self.write_seconds = 0.0  # [s] spent in them
        self._last_end = -math.inf
        self._last_cost = 0.0

    def read(self) -> list[dict[str, Any]]:
        """The rows of an existing file ([] if there is none)."""
        if not self.path.is_file():
            return []
        return pq.read_table(self.path).to_pylist()

    def add(self, case: Case, outcome: Mapping[str, Any], write: bool = True) -> dict[str, Any]:
        """Record one case's outcome (replacing a row of the same hash); rewrite the file if
        ``write``.

        Parameters
        ----------
        case : Case
            The case.
        outcome : mapping
            Its outcome (:func:`~.engine.run_case`).
        write : bool
            Rewrite the file.

        Returns
        -------
        dict
            The row.
        """
        outcome = dict(outcome)
        self.signals.add(case.case_hash, outcome.pop(SIGNALS, None))
        row = {**case_columns(case), **{k: None for k in SUMMARY_TYPES}, **outcome}
        row.update(case.values)  # a case column the summary also has (scenario) is the case's
        row["scenario_toml"] = case.scenario_toml
        self.rows[case.case_hash] = row
        self.dirty = True
        if write:
            self.write()
        return row

    def keep(self, row: Mapping[str, Any], case: Case) -> None:
        """Keep a finished row of an earlier run of the campaign (renumbered as ``case``).

        Parameters
        ----------
        row : mapping
            The earlier row.
        case : Case
            The case it is now.
        """
        self.rows[case.case_hash] = {**dict(row), **case_columns(case)}

    def table(self) -> pa.Table:
        """The rows so far as an Arrow table, sorted by case, with the file's column types."""
        rows = sorted(self.rows.values(), key=lambda r: r["case"])
        known = {**HEAD, **{k: None for k in self.key_columns}, **MIDDLE, **SUMMARY_TYPES}
        names = list(known)
        for row in rows:
            names += [k for k in row if k not in known and k not in TAIL and k not in names]
        names += list(TAIL)
        arrays, fields = [], []
        for name in names:
            values = [row.get(name) for row in rows]
            typ = {**known, **TAIL, **OPTIONAL_TYPES}.get(name) or _infer(values)
            arrays.append(pa.array(values, type=typ))
            fields.append(pa.field(name, typ))
        return pa.Table.from_arrays(arrays, schema=pa.schema(fields))

    def write_due(self) -> bool:
        """Whether a rewrite now keeps to ``min_interval_s`` and ``write_share``."""
        wait = max(self.min_interval_s, self._last_cost / self.write_share)
        return self.dirty and time.perf_counter() - self._last_end >= wait

    def flush(self) -> None:
        """Rewrite the file if rows were added since the last write."""
        if self.dirty:
            self.write()

    def write(self) -> None:
        """Write the file atomically: a temporary file in the same folder, then a rename
        (``signals.parquet`` first, the same way)."""
        start = time.perf_counter()
        self.signals.write({h: row["case"] for h, row in self.rows.items()})
        with replaced_file(self.path) as tmp:
            pq.write_table(self.table(), tmp)
        self.dirty = False
        self._last_end = time.perf_counter()
        self._last_cost = self._last_end - start
        self.writes += 1
        self.write_seconds += self._last_cost


def _infer(values: list[Any]) -> pa.DataType:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.int64() if all(isinstance(v, int) for v in present) else pa.float64()
    if not present:
        return pa.null()
    return pa.array(present).type
