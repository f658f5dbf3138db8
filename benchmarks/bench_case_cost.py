"""What a campaign case costs outside its loop, piece by piece, old way against new, in one process.

Usage::

    python benchmarks/bench_case_cost.py                 # case 1 and spatial-realistic, 1 s
    python benchmarks/bench_case_cost.py --duration 4 --repeat 9

For each robot one case is run (lu-jia, perturbed estimates), then timed round-robin
(``_timing.time_interleaved``: a change of machine load hits every item alike):

* ``min_sigma_gjm, row by row``: what a case did before issue 38's per-case slice: a full
  ``State.update``, ``State.generalized_jacobian`` and an SVD per kept row (500), ``min`` over them;
* ``min_sigma_gjm, stacked``: :func:`ffsm_pin.sweep.explain.min_sigma_gjm` as it is
  (kinematics-only updates, one stacked solve and SVD); both give the same bits (checked here
  too);
* ``prepare`` of the case (its robot from a batch's copy) and ``case_extras`` as a whole;
* ``example-robot-data folder, file list`` (the look-up every robot load made) against
  ``..., cached`` (:func:`ffsm_pin.robot.urdf.example_robot_data_dir`);
* ``DuckDB, connect per query`` against ``DuckDB, shared connection``
  (:func:`ffsm_pin.sweep.report.sql.query`) on the case's results.parquet-like table.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from _timing import checkout, time_interleaved  # noqa: E402


def _erd_scan() -> Path:
    """The share folder found from the distribution's file list (the uncached look-up)."""
    from ffsm_pin.robot import urdf

    urdf._ERD_SHARE.clear()
    return urdf.example_robot_data_dir()


def _duckdb_fresh(text: str) -> list:
    import duckdb

    con = duckdb.connect()
    try:
        return con.execute(text).fetchall()
    finally:
        con.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=1.0, help="simulated seconds")
    parser.add_argument("--repeat", type=int, default=7, help="samples per item")
    args = parser.parse_args()

    import pyarrow as pa
    import pyarrow.parquet as pq

    from ffsm_pin.model.state import State
    from ffsm_pin.robot.urdf import example_robot_data_dir
    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.robots import SharedRobots
    from ffsm_pin.sim.run import prepare, simulate
    from ffsm_pin.sweep.explain import (
        case_extras,
        kept_rows,
        min_sigma_gjm,
    )
    from ffsm_pin.sweep.report.sql import query

    load = os.getloadavg()
    print(f"case cost: {checkout(HERE.parent)}, {os.cpu_count()} CPU(s), load "
          f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, {args.duration} s cases, "
          f"{args.repeat} samples")  # fmt: skip
    warnings.simplefilter("ignore")
    for name in ("case1", "spatial-realistic"):
        sc = builtin_scenario(name)
        sc = dataclasses.replace(sc, duration=args.duration)
        robots = SharedRobots()
        setup = prepare(sc, robots=robots)
        res = simulate(setup)
        summary = res.summary()
        s = res.signals
        rows = kept_rows(len(s["t"]))

        def row_by_row(setup=setup, s=s, rows=rows):
            state = State(setup.robot)
            return min(
                float(np.linalg.svd(J, compute_uv=False)[-1])
                for J in (
                    state.update(s["q"][i], s["v"][i]).generalized_jacobian(setup.n_task)
                    for i in rows
                )
            )

        old, new = row_by_row(), min_sigma_gjm(setup, s, rows)
        assert np.float64(old).tobytes() == np.float64(new).tobytes(), (old, new)
        fns = {
            "min_sigma_gjm, row by row": row_by_row,
            "min_sigma_gjm, stacked": lambda setup=setup, s=s, rows=rows: min_sigma_gjm(
                setup, s, rows
            ),
            "case_extras": lambda setup=setup, res=res, summary=summary: case_extras(
                setup, res, summary
            ),
            "prepare (batch's robot)": lambda sc=sc, robots=robots: prepare(sc, robots=robots),
        }
        times = time_interleaved(fns, repeat=args.repeat, number=1)
        print(f"\n{name} ({len(rows)} kept rows of {len(s['t'])}):")
        for item, t in times.items():
            print(f"  {item:28s} {t.median_us / 1e3:8.2f} ms  (IQR {t.iqr_us / 1e3:.2f})")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "t.parquet"
        pq.write_table(pa.table({"x": np.arange(200.0), "k": np.arange(200) % 3}), path)
        text = f"SELECT k, avg(x) AS m, count(*) AS n FROM read_parquet('{path}') GROUP BY k"
        fns = {
            "example-robot-data folder, file list": _erd_scan,
            "example-robot-data folder, cached": example_robot_data_dir,
            "DuckDB, connect per query": lambda: _duckdb_fresh(text),
            "DuckDB, shared connection": lambda: query(text),
        }
        times = time_interleaved(fns, repeat=args.repeat, number=1)
    print("\nper call:")
    for item, t in times.items():
        print(f"  {item:38s} {t.median_us / 1e3:8.2f} ms  (IQR {t.iqr_us / 1e3:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
