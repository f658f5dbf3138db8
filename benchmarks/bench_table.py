"""Cost of keeping results.parquet up to date during a campaign (ffsm_pin.sweep.table).

The rows are those of the built-in ``robustness-case1`` campaign's cases (301, the
table repeated to the sizes asked) with a typical summary each. For each table size n the
median time of one atomic rewrite of n rows is measured; from those:

* rewriting after every row (the policy before): sum over k = 1..N of write(k), quadratic in N;
* the throttled policy (``ResultsTable.write_due``): at most ``write_share`` (1 %) of the wall
  time plus one final write, whatever N.

    python benchmarks/bench_table.py [--sizes 100 500 1000 2000] [--case-s 0.85]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import time_call  # noqa: E402

from ffsm_pin.sweep.campaign import builtin_campaign_path, load_campaign  # noqa: E402
from ffsm_pin.sweep.cases import expand  # noqa: E402
from ffsm_pin.sweep.table import ResultsTable  # noqa: E402

OUTCOME = {
    "status": "completed", "error": None, "scheme": "ppc", "robot": "ffsm_planar4",
    "dt": 1e-3, "duration": 30.0, "steps": 30000, "simulated_time": 30.0, "wall_time_s": 2.1,
    "steps_per_s": 14000.0, "funnel_ok_b": True, "funnel_ok_z": True, "first_violation_t": None,
    "max_abs_u": 12.5, "drift_P": 1e-15, "drift_L": 3e-15, "settle_time_b": 4.0,
    "settle_time_z": 6.0, "completed": True, "stop_reason": None, "stop_time": None,
    "min_sigma": 0.08, "damped_fraction": 0.0, "max_abs_F_r": 3.0, "case_wall_s": 2.2,
    "case_cpu_s": 2.1,
}  # fmt: skip


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[100, 250, 500, 1000, 2000])
    p.add_argument(
        "--case-s", type=float, default=0.6, help="CPU time of one case [s] (bench_sweep.py)"
    )
    p.add_argument("--workers", type=int, nargs="+", default=[2, 64])
    args = p.parse_args(argv)
    campaign = load_campaign(builtin_campaign_path("robustness-case1"))
    cases = expand(campaign)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        table = ResultsTable(Path(tmp) / "results.parquet", campaign.columns)
        n_max = max(args.sizes)
        for k in range(n_max):
            case = cases[k % len(cases)]
            case = case._replace(case_hash=f"{case.case_hash}-{k}", index=k) if hasattr(
                case, "_replace") else _copy(case, k)  # fmt: skip
            table.add(case, OUTCOME, write=False)
            rows[k] = table.rows[case.case_hash]
        print(f"{'rows':>6} {'one rewrite [ms]':>17} {'q1-q3':>14} {'per row [us]':>13}")
        sizes, costs = [], []
        for n in sorted(args.sizes):
            table.rows = {str(k): rows[k] for k in range(n)}
            t = time_call(table.write, repeat=7, number=1)
            sizes.append(n)
            costs.append(t.median_us * 1e-6)
            print(f"{n:6d} {t.median_us / 1e3:17.1f} {t.q1_us / 1e3:6.1f}-{t.q3_us / 1e3:6.1f}"
                  f" {t.median_us / n:13.1f}")  # fmt: skip
    # write(k) ~ a + b k (least squares over the sizes measured)
    b, a = np.polyfit(sizes, costs, 1)
    print(f"\nfit: one rewrite of k rows = {a * 1e3:.2f} ms + {b * 1e6:.2f} us x k")
    print(
        "\nrows arriving every case_s / workers seconds; time the campaign's process spends "
        "rewriting, as a share of the campaign's wall time (virtual clock, fitted costs):"
    )
    print(f"{'cases':>7} {'workers':>7} {'wall [s]':>9} {'every row':>10} {'throttled':>10} "
          f"{'rewrites':>9}")  # fmt: skip
    for workers in args.workers:
        for n in sorted(args.sizes):
            gap = args.case_s / workers
            every = sum(a + b * k for k in range(1, n + 1))
            spent, writes, last_end, last_cost = 0.0, 0, -np.inf, 0.0
            for k in range(1, n + 1):  # ResultsTable.write_due with its defaults
                now = max(k * gap, last_end)
                if now - last_end >= max(1.0, last_cost / 0.01):
                    last_cost = a + b * k
                    spent, writes, last_end = spent + last_cost, writes + 1, now + last_cost
            spent += a + b * n  # the final flush
            wall = n * gap
            print(f"{n:7d} {workers:7d} {wall:9.0f} {100 * every / wall:9.2f}% "
                  f"{100 * spent / wall:9.2f}% {writes + 1:9d}")  # fmt: skip
    return 0


def _copy(case, k):
    import dataclasses

    return dataclasses.replace(case, case_hash=f"{case.case_hash}-{k}", index=k)


if __name__ == "__main__":
    raise SystemExit(main())
