"""A small campaign, the DuckDB query of its results, and a plot.

Two controllers on case 1, two parameter errors, two seeds each: 9 short runs on a local Dask
cluster, results.parquet, report.md, then one query of your own and its figure.

    python examples/small_campaign.py --out campaigns/example
"""

import argparse
import os
import subprocess
import sys
from pathlib import Path

import duckdb
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--out", default="campaigns/example", help="output folder")
parser.add_argument("--duration", type=float, default=2.0, help="simulated time per run [s]")
args = parser.parse_args()
out = Path(args.out)
out.mkdir(parents=True, exist_ok=True)

campaign = out.parent / f"{out.name}.toml"
campaign.write_text(f"""
[campaign]
name = "example"
scenario = "case1"
seed = 1
repeat = 2
duration = {args.duration}

[campaign.set]
"controller.estimates.initial" = "perturbed"

[[vary]]
key = "controller.type"
values = ["lu-jia", "gjm-ct"]

[[vary]]
key = "controller.estimates.spread"
values = [0.1, 0.3]
""")
cmd = [sys.executable, "-m", "ffsm_pin.sweep", str(campaign), "--out", str(out), "--quiet"]
workers = max(1, min(4, os.cpu_count() or 1))  # this machine's cores (at most 4 for a demo)
subprocess.run(cmd + ["--workers", str(workers)], check=True)
print("report:", out / "report.md")

rows = duckdb.sql(f"""
    SELECT "controller.type" AS controller, "controller.estimates.spread" AS spread,
           avg(rms_err_z_late) AS rms, max(max_abs_u) AS max_u
    FROM '{out / "results.parquet"}' WHERE NOT nominal
    GROUP BY ALL ORDER BY ALL
""").fetchall()
for r in rows:
    print(f"{r[0]:8s} spread {r[1]:.1f}: mean RMS e_z {r[2]:.3g}, max |u_m| {r[3]:.4g} N m")

fig, ax = plt.subplots(figsize=(5, 3.5))
for kind in sorted({r[0] for r in rows}):
    pts = [(r[1], r[2]) for r in rows if r[0] == kind]
    ax.plot(*zip(*pts, strict=True), "o-", label=kind)
ax.set_xlabel("parameter error (spread)")
ax.set_ylabel("mean RMS e_z, last half")
ax.legend()
fig.tight_layout()
fig.savefig(out / "fig_rms.png", dpi=100)
print("figure:", out / "fig_rms.png")
