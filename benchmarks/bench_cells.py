"""The performance issue's campaign measure, in one command: the planar or the spatial cells of
the shipped ``compare-controllers`` campaign as a campaign of their own on one worker, the
whole command's wall time over its simulated steps, beside the bare Python plant loop of the
cells' own scenarios in the same invocation.

Usage::

    python benchmarks/bench_cells.py                      # planar and spatial cells, 2 trials
    python benchmarks/bench_cells.py --cells planar --trials 3

The cells: ``planar`` runs the campaign with ``scenario = ["case1", "planar5"]`` (122 cases),
``spatial`` with ``scenario = ["spatial-realistic"]`` (61 cases); everything else as shipped
(the three controllers, both spreads, ten seeds, actuators and sensors on). Each trial is
``python -m ffsm_pin.sweep FILE --out DIR --workers 1 --quiet --force`` in a child process, so
its wall time is what a user waits for: the interpreter's start, the cluster, the warm-ups,
the cases and the report. Before the trials one short campaign of the same cells (0.05 s
cases) loads or compiles their kernels, so that no trial times numba's compilation (the first
campaign after a change of the kernels compiles them: benchmarks/README.md, "The campaigns as
the issue measures them").

Printed per trial and cells: the campaign's wall time over its steps, the cases' CPU
(``case_cpu_s``) and their loops (``wall_time_s``) over the same steps, and the bare Python
loop of ``bench_run.py`` (Pinocchio ABA, integrate, momentum projection) measured just before
it for each of the cells' scenarios (the median of three 1 s loops), weighted by that
scenario's steps in the campaign; the ratios to it and the medians over trials; then, for the
last trial, each cell's (scenario and controller) case CPU and loops over its steps. The
issue's targets: planar <= 2.5x, spatial <= 4x.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import pyarrow.parquet as pq  # noqa: E402
from _timing import checkout  # noqa: E402
from bench_run import bare_loop  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: the cells' scenarios, and the issue's target ratio for them
CELLS = {"planar": (("case1", "planar5"), 2.5), "spatial": (("spatial-realistic",), 4.0)}
#: [s] simulated by each bare-loop measurement, and how many are taken (their median counts:
#: one of two trials once read 12.2 us for a loop of 9.1-9.4, a moment of the machine's)
BARE_SECONDS, BARE_REPEATS = 1.0, 3


def cells_campaign(cells: str, duration: float | None = None) -> str:
    """The text of ``compare-controllers`` restricted to the scenarios of ``cells`` (their
    ``[campaign.set_for.*]`` tables kept, the others dropped), with every case's duration
    ``duration`` [s] when given."""
    from ffsm_pin.sweep.campaign import builtin_campaign_path

    scenarios, _ = CELLS[cells]
    lines, keep = [], True
    for line in builtin_campaign_path("compare-controllers").read_text().splitlines():
        header = re.match(r"\[campaign\.set_for\.([\w-]+)\]", line)
        if header:
            keep = header.group(1) in scenarios
        elif line.startswith("["):
            keep = True
        if not keep:
            continue
        if line.startswith("scenario ="):
            line = "scenario = [" + ", ".join(f'"{s}"' for s in scenarios) + "]"
        elif line.startswith("name ="):
            line = f'name = "compare-controllers-{cells}"'
        lines.append(line)
        if line == "[campaign]" and duration is not None:
            lines.append(f"duration = {duration}")
    return "\n".join(lines) + "\n"


def run_campaign(path: Path, out: Path) -> float:
    """Wall time [s] of the campaign command in a child process, one worker."""
    cmd = [sys.executable, "-m", "ffsm_pin.sweep", str(path), "--out", str(out),
           "--workers", "1", "--quiet", "--force"]  # fmt: skip
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr[-2000:]}")
    return wall


def _bare_step(scenario: str) -> float:
    """The bare Python loop's time a step [s] on ``scenario``: the median of
    :data:`BARE_REPEATS` loops of :data:`BARE_SECONDS`."""
    runs = [bare_loop(scenario, BARE_SECONDS) for _ in range(BARE_REPEATS)]
    return statistics.median(r["python_wall_time_s"] / r["steps"] for r in runs)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cells", nargs="+", choices=sorted(CELLS), default=sorted(CELLS))
    p.add_argument("--trials", type=int, default=2, help="timed campaigns per cells (default 2)")
    args = p.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bench_cells_"))
    rows: dict[str, list[dict[str, float]]] = {c: [] for c in args.cells}
    cell_rows: dict[str, list[str]] = {}  # the last trial's, per scenario and controller
    load = os.getloadavg()[0]
    print(f"ffsm-pin cells benchmark: {checkout(ROOT)}, python {sys.version.split()[0]}, "
          f"os.cpu_count() = {os.cpu_count()}, load average {load:.2f} (start)")  # fmt: skip
    try:
        paths = {}
        for cells in args.cells:
            paths[cells] = tmp / f"{cells}.toml"
            paths[cells].write_text(cells_campaign(cells))
            warm = tmp / f"{cells}-warm.toml"
            warm.write_text(cells_campaign(cells, duration=0.05))
            run_campaign(warm, tmp / f"{cells}-warm")  # kernels compiled or loaded
        for k in range(args.trials):
            for cells in args.cells:
                bare = {s: _bare_step(s) for s in CELLS[cells][0]}
                out = tmp / f"{cells}-{k}"
                wall = run_campaign(paths[cells], out)
                table = pq.read_table(out / "results.parquet").to_pylist()
                steps = sum(r["steps"] for r in table)
                by_scenario = {s: sum(r["steps"] for r in table if r["scenario"] == s)
                               for s in bare}  # fmt: skip
                bare_step = sum(by_scenario[s] * b for s, b in bare.items()) / max(
                    1, sum(by_scenario.values())
                )
                row = {
                    "cases": len(table), "steps": steps, "wall": wall, "bare": bare_step,
                    "per_step": wall / steps,
                    "cpu": sum(r["case_cpu_s"] for r in table) / steps,
                    "loops": sum(r["wall_time_s"] for r in table) / steps,
                }  # fmt: skip
                rows[cells].append(row)
                cell_rows[cells] = _per_cell(table)
                print(f"trial {k + 1} {cells}: {len(table)} cases, {steps} steps, wall {wall:.1f} "
                      f"s: {1e6 * row['per_step']:.1f} us a step, {row['per_step'] / bare_step:.2f}"
                      f"x the bare loop ({1e6 * bare_step:.2f} us)", flush=True)  # fmt: skip
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"\nload average {os.getloadavg()[0]:.2f} (end); medians over {args.trials} trials")
    print("| cells | cases, steps | wall / steps [us] | / bare loop (target) | case CPU / steps "
          "| loops / steps | bare Python loop [us] |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for cells, rs in rows.items():
        med = {key: statistics.median(r[key] for r in rs) for key in rs[0]}
        ratios = [r["per_step"] / r["bare"] for r in rs]
        target = CELLS[cells][1]
        print(
            f"| {cells} | {int(med['cases'])}, {int(med['steps'])} | {1e6 * med['per_step']:.1f} "
            f"| {statistics.median(ratios):.2f}x ({' '.join(f'{x:.2f}' for x in ratios)}; "
            f"<= {target}x) | {1e6 * med['cpu']:.1f} ({med['cpu'] / med['bare']:.2f}x) | "
            f"{1e6 * med['loops']:.1f} ({med['loops'] / med['bare']:.2f}x) | "
            f"{1e6 * med['bare']:.2f} |"
        )
    print("\nper cell, the last trial: case CPU / steps | loops / steps [us]")
    for cells, lines in cell_rows.items():
        print(f"{cells}: " + "; ".join(lines))
    return 0


def _per_cell(table: list[dict]) -> list[str]:
    """Per scenario and controller of a campaign's rows: its cases' CPU and loops over its
    steps [us] (where a campaign's time goes, cell by cell)."""
    cells: dict[tuple[str, str], list[dict]] = {}
    for r in table:
        cells.setdefault((r["scenario"], r["controller.type"]), []).append(r)
    out = []
    for (scenario, controller), rs in sorted(cells.items()):
        steps = sum(r["steps"] for r in rs)
        cpu = sum(r["case_cpu_s"] for r in rs) / steps
        loops = sum(r["wall_time_s"] for r in rs) / steps
        out.append(f"{scenario} {controller} {1e6 * cpu:.1f} | {1e6 * loops:.1f}")
    return out


if __name__ == "__main__":
    raise SystemExit(main())
