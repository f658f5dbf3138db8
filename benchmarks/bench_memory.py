"""Peak memory and wall time of whole runs against their duration (issue 20).

Every run is one ``python -m ffsm_pin.sim`` in a fresh process (``--no-plots --no-html``,
recording every step), which reports its own peak resident memory (``ru_maxrss``). Two
recorders side by side, in the same invocation, rows interleaved:

* ``stream``: the package's recorder (one 32 MiB chunk in memory, the rest spooled to disk);
* ``memory``: the same recorder with a chunk as large as the run, i.e. every row held in memory
  until the end, as before the streaming recorder (the baseline).

Usage::

    python benchmarks/bench_memory.py                       # planar and spatial, 40 and 400 s
    python benchmarks/bench_memory.py --durations 40 400 4000 --recorders stream

Printed per run: peak memory [MB], its ratio to the first (shortest) run of the same case and
recorder, the loop's wall time [s] and steps per second (the summary's), the whole process's
wall time [s] (start-up, compile-cache load, writing ``trajectory.npz``) and the file's size.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CASES = {"planar": "1", "spatial": "spatial", "spatial-realistic": "spatial-realistic"}
CHILD = """
import resource, sys
import ffsm_pin.sim.recorder as recorder
if sys.argv[1] == "memory":
    recorder.CHUNK_BYTES = 1 << 60  # one chunk as large as the run: everything in memory
from ffsm_pin.sim.cli import main
rc = main(sys.argv[2:])
print("MAXRSS_KB", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)
sys.exit(rc)
"""


def run(case: str, duration: float, recorder: str, out: Path) -> dict:
    """One run in a fresh process; its peak memory, wall time and summary."""
    cmd = [sys.executable, "-c", CHILD, recorder, "--case", CASES[case]]
    cmd += ["--duration", str(duration), "--no-plots", "--no-html", "--quiet", "--out", str(out)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    total = time.perf_counter() - t0
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{case} {duration} s ({recorder}): exit {proc.returncode}\n{proc.stderr}")
    kb = int(proc.stderr.split("MAXRSS_KB")[1].split()[0])
    summary = json.loads((out / "summary.json").read_text())
    npz = (out / "trajectory.npz").stat().st_size
    return {"rss_mb": kb / 1024, "summary": summary, "npz_mb": npz / 2**20, "total_s": total}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--durations", type=float, nargs="+", default=[40.0, 400.0])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=["planar", "spatial"])
    parser.add_argument("--recorders", nargs="+", choices=["stream", "memory"],
                        default=["stream", "memory"])  # fmt: skip
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"ffsm-pin memory benchmark: python {sys.version.split()[0]}, {os.cpu_count()} CPU(s), "
          f"load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")  # fmt: skip
    print(f"{'case':8s} {'duration':>9s} {'recorder':8s} {'peak MB':>8s} {'vs 1st':>7s} "
          f"{'loop s':>8s} {'steps/s':>8s} {'total s':>8s} {'npz MB':>8s}")  # fmt: skip
    first: dict[tuple[str, str], float] = {}
    with tempfile.TemporaryDirectory(prefix="ffsm-bench-mem-") as tmp:
        for case in args.cases:
            for duration in args.durations:
                for rec in args.recorders:  # interleaved: load changes hit both alike
                    out = Path(tmp) / f"{case}-{duration:g}-{rec}"
                    r = run(case, duration, rec, out)
                    base = first.setdefault((case, rec), r["rss_mb"])
                    s = r["summary"]
                    row = (
                        f"{case:8s} {duration:9g} {rec:8s} {r['rss_mb']:8.0f} "
                        f"{r['rss_mb'] / base:7.2f} {s['wall_time_s']:8.1f} "
                        f"{s['steps_per_s']:8.0f} {r['total_s']:8.1f} {r['npz_mb']:8.0f}"
                    )
                    print(row, flush=True)
                    subprocess.run(["rm", "-rf", str(out)], check=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
