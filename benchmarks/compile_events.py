"""What a first run compiles: numba's compile events in every process of one run.

Runs ``python -m ffsm_pin.sim --case C --duration D --no-plots --no-html --quiet`` (0.01 s
simulated by default, ``--check`` for a check) from an empty numba cache (``XDG_CACHE_HOME``
an empty folder) with a ``sitecustomize`` module first on ``PYTHONPATH`` that registers a
listener of numba's ``"numba:compile"`` events in the run's process and in the second process
of its first compilation (:mod:`ffsm_pin.control._first_compile`), which inherits
``PYTHONPATH``. Each event is the CPU time of compiling one function for one set of argument
types (``time.process_time`` of that process), less sensitive to other jobs on the machine
than wall time.

Usage::

    python benchmarks/compile_events.py --case case1                 # summary by process
    python benchmarks/compile_events.py --case spatial --top 40      # the 40 largest items
    python benchmarks/compile_events.py --case case1 --list          # every compiled function
    python benchmarks/compile_events.py --case case1 --source ../other-checkout

Printed per process: the number of events, the CPU time of the top-level compilations and
the wall time from its first event to its last; then the functions by their own (exclusive)
CPU time, with their inclusive time and count.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: The listener, written as ``sitecustomize.py``: one JSON line per event, appended at its
#: end (a process that exits early keeps what it wrote).
SITECUSTOMIZE = r"""
import json, os, threading, time
_log = os.environ.get("FFSM_COMPILE_EVENTS")
if _log:
    import ffsm_pin  # first: the package's numba settings (its cache folder) before numba loads
    from numba.core import event

    class _Listener(event.Listener):
        def __init__(self):
            self.stack = threading.local()

        def on_start(self, ev):
            st = getattr(self.stack, "s", None)
            if st is None:
                st = self.stack.s = []
            st.append([time.process_time(), time.time(), 0.0])

        def on_end(self, ev):
            st = self.stack.s
            c0, w0, child = st.pop()
            cpu = time.process_time() - c0
            if st:
                st[-1][2] += cpu
            d = ev.data or {}
            disp = d.get("dispatcher")
            f = getattr(disp, "py_func", None)
            name = f"{f.__module__}.{f.__qualname__}" if f else str(disp)
            sig = str(d.get("args", ""))[:300]
            rec = {"pid": os.getpid(), "name": name, "args": sig, "cpu": cpu,
                   "own": cpu - child, "depth": len(st), "t0": w0, "t1": time.time()}
            with open(_log, "a") as fh:
                fh.write(json.dumps(rec) + "\n")

    event.register("numba:compile", _Listener())
"""


def record(case: str, source: Path, duration: float, check: bool, tmp: Path) -> list[dict]:
    """The compile events of one run of ``case`` from ``source`` with an empty cache."""
    site = tmp / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
    log = tmp / "events.jsonl"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(source)]),
           "XDG_CACHE_HOME": str(tmp / "xdg"), "FFSM_COMPILE_EVENTS": str(log)}  # fmt: skip
    env.pop("NUMBA_CACHE_DIR", None)
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--case", case, "--no-plots", "--no-html",
           "--quiet", "--out", str(tmp / "run")]  # fmt: skip
    cmd += ["--check"] if check else ["--duration", str(duration)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp)
    wall = time.perf_counter() - t0
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr}")
    time.sleep(0.5)  # (a second process still finishing its last write)
    events = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    print(f"{case}{' --check' if check else ''} from {source}: wall {wall:.1f} s, "
          f"{len(events)} compile events", flush=True)  # fmt: skip
    return events


def summarize(events: list[dict], top: int, listing: bool) -> None:
    """Print the events by process, then by function (own and inclusive CPU time)."""
    pids = sorted({e["pid"] for e in events}, key=lambda p: min(e["t0"] for e in events
                                                               if e["pid"] == p))  # fmt: skip
    for k, pid in enumerate(pids):
        mine = [e for e in events if e["pid"] == pid]
        cpu = sum(e["cpu"] for e in mine if e["depth"] == 0)
        span = max(e["t1"] for e in mine) - min(e["t0"] for e in mine)
        print(
            f"process {k} ({'run' if k == 0 else 'second'}): {len(mine)} events, "
            f"top-level compile CPU {cpu:.1f} s, first to last event {span:.1f} s"
        )
        own: dict[str, float] = collections.defaultdict(float)
        inc: dict[str, float] = collections.defaultdict(float)
        count: dict[str, int] = collections.Counter()
        for e in mine:
            own[e["name"]] += e["own"]
            inc[e["name"]] += e["cpu"]
            count[e["name"]] += 1
        for name in sorted(own, key=own.get, reverse=True)[:top]:  # type: ignore[arg-type]
            print(f"    own {own[name]:6.2f}  incl {inc[name]:6.2f}  x{count[name]:<3d} {name}")
        if listing:
            for e in sorted(mine, key=lambda e: e["t0"]):
                print(f"    {'  ' * e['depth']}{e['cpu']:6.2f} {e['name']} {e['args']}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", default="case1")
    parser.add_argument("--duration", type=float, default=0.01)
    parser.add_argument("--check", action="store_true", help="run --check instead of a run")
    parser.add_argument("--source", type=Path, default=ROOT, help="the checkout to run")
    parser.add_argument("--top", type=int, default=25, help="functions listed per process")
    parser.add_argument("--list", action="store_true", help="every event, nested")
    parser.add_argument("--save", type=Path, default=None, help="write the events (JSON)")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, {os.cpu_count()} CPU(s)")
    with tempfile.TemporaryDirectory(prefix="ffsm-compile-events-") as tmp:
        events = record(args.case, args.source.resolve(), args.duration, args.check, Path(tmp))
    if args.save is not None:
        args.save.write_text(json.dumps(events))
    summarize(events, args.top, args.list)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
