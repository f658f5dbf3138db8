"""What the first run of a fresh installation costs: a whole run from an empty numba cache.

Each sample is one ``python -m ffsm_pin.sim --case C --no-plots --no-html --quiet`` in a fresh
process with ``XDG_CACHE_HOME`` pointing to an empty folder (so the package's numba cache,
``$XDG_CACHE_HOME/ffsm-pin/numba``, starts empty), timed from the process start to its exit:
what a user waits for after ``pip install``. Then the same run once more with that cache
warm, and once more from a copy of the package in another folder (``ffsm_pin/``, with
``urdf/`` as ``ffsm_pin/urdf`` as pip installs it) with the same cache: a second import path,
which should compile nothing (column ``copy``). With ``--baseline REV`` the same is done,
interleaved, for a git revision checked out beside this one (default: none).

With ``--campaign NAME`` the built-in campaign is timed the same way, cold and then warm
(``python -m ffsm_pin.sweep NAME --out DIR --workers W --quiet``), its wall time and the CPU
time of all its processes (the campaign's, the cluster's workers and their children, from
``getrusage(RUSAGE_CHILDREN)``): what a first campaign after an install or an update costs.

Usage::

    python benchmarks/bench_first_run.py                       # case 1 and spatial, 2 samples
    python benchmarks/bench_first_run.py --cases case1 --repeat 3 --baseline 411cfc5
    python benchmarks/bench_first_run.py --cases --campaign compare-controllers --repeat 1

Printed per case and side: the median cold, warm and copy wall times [s] and the cold samples;
per campaign and side: the median cold and warm wall and CPU times [s].
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import checkout

ROOT = Path(__file__).resolve().parents[1]


def timed(args: list[str], source: Path, xdg: Path, out: Path) -> tuple[float, float]:
    """(wall, CPU) [s] of ``python -m ARGS --out OUT`` from ``source`` with cache home ``xdg``;
    the CPU time of the process and of every process it waited for."""
    env = {**os.environ, "PYTHONPATH": str(source), "XDG_CACHE_HOME": str(xdg)}
    env.pop("NUMBA_CACHE_DIR", None)  # the package then picks $XDG_CACHE_HOME/ffsm-pin/numba
    shutil.rmtree(out, ignore_errors=True)  # (a campaign resumes from a folder it finds)
    cmd = [sys.executable, "-m", *args, "--out", str(out)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=out.parent)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr}")
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return wall, cpu


def timed_run(case: str, source: Path, xdg: Path, out: Path) -> float:
    """Wall time [s] of one whole CLI run of ``case`` from ``source`` with cache home ``xdg``."""
    args = ["ffsm_pin.sim", "--case", case, "--no-plots", "--no-html", "--quiet"]
    return timed(args, source, xdg, out)[0]


def installed_copy(source: Path, dest: Path) -> Path:
    """``source``'s package copied to ``dest`` as pip installs it (``urdf/`` inside); ``dest``."""
    if not dest.exists():
        skip = shutil.ignore_patterns("__pycache__")
        shutil.copytree(source / "ffsm_pin", dest / "ffsm_pin", ignore=skip)
        shutil.copytree(source / "urdf", dest / "ffsm_pin" / "urdf", ignore=skip)
    return dest


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="*", default=["case1", "spatial"])
    parser.add_argument("--campaign", nargs="*", default=[], help="built-in campaigns to time")
    parser.add_argument("--workers", type=int, default=2, help="a campaign's workers")
    parser.add_argument("--repeat", type=int, default=2, help="cold samples per case and side")
    parser.add_argument("--baseline", default=None, help="a git revision to compare with")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"ffsm-pin first-run benchmark: {checkout(ROOT)}, python "
          f"{sys.version.split()[0]}, {os.cpu_count()} CPU(s), load {load[0]:.2f} "
          f"{load[1]:.2f} {load[2]:.2f}", flush=True)  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="ffsm-bench-first-") as tmp_name:
        tmp = Path(tmp_name)
        sides = {"HEAD": ROOT}
        if args.baseline:
            base = tmp / "baseline"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q",
                            str(base), args.baseline], check=True)  # fmt: skip
            sides = {args.baseline: base, "HEAD": ROOT}
        try:
            for case in args.cases:
                cold: dict[str, list[float]] = {s: [] for s in sides}
                warm: dict[str, list[float]] = {s: [] for s in sides}
                copy: dict[str, list[float]] = {s: [] for s in sides}
                for k in range(args.repeat):
                    for label, source in sides.items():
                        xdg = tmp / f"xdg-{case}-{label}-{k}"
                        xdg.mkdir()
                        cold[label].append(timed_run(case, source, xdg, tmp / "run"))
                        warm[label].append(timed_run(case, source, xdg, tmp / "run"))
                        other = installed_copy(source, tmp / f"copy-{label}")
                        copy[label].append(timed_run(case, other, xdg, tmp / "run"))
                for label in sides:
                    print(f"{case:10s} {label:>10s}  cold {statistics.median(cold[label]):6.1f} s"
                          f"  warm {statistics.median(warm[label]):6.1f} s"
                          f"  copy {statistics.median(copy[label]):6.1f} s   cold samples "
                          + " ".join(f"{x:.1f}" for x in cold[label]), flush=True)  # fmt: skip
            for name in args.campaign:
                times: dict[tuple[str, str], list[tuple[float, float]]] = {}
                sweep = ["ffsm_pin.sweep", name, "--workers", str(args.workers), "--quiet"]
                for k in range(args.repeat):
                    for label, source in sides.items():
                        xdg = tmp / f"xdg-{name}-{label}-{k}"
                        xdg.mkdir()
                        for state in ("cold", "warm"):
                            sample = timed(sweep, source, xdg, tmp / "campaign")
                            times.setdefault((label, state), []).append(sample)
                for label in sides:
                    line = [f"{name:10s} {label:>10s}"]
                    for state in ("cold", "warm"):
                        walls, cpus = zip(*times[label, state], strict=True)
                        line.append(f"{state} {statistics.median(walls):6.1f} s wall "
                                    f"{statistics.median(cpus):6.1f} s CPU")  # fmt: skip
                    print("  ".join(line), flush=True)
        finally:
            if args.baseline:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                str(tmp / "baseline")], check=False)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
