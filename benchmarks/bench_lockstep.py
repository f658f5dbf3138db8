"""What a campaign case costs run in lock-step with the other cases of its batch
(:func:`ffsm_pin.sim.lockstep.simulate_lockstep`, what a campaign's worker does), against the
same cases run one by one by :func:`ffsm_pin.sim.loop.simulate`, in the same invocation, and
checked against them signal by signal.

Usage::

    python benchmarks/bench_lockstep.py                       # 8 case-1 cases, 5 s each
    python benchmarks/bench_lockstep.py --scenario spatial-realistic --duration 4
    python benchmarks/bench_lockstep.py --batch 16 --duration 10 --repeat 3
    python benchmarks/bench_lockstep.py --controller gjm-ct

The cases are the first ``--batch`` cases of the shipped campaign ``compare-controllers`` for
``--scenario`` (``case1``, ``planar5`` or ``spatial-realistic``) and ``--controller`` (the
paper's by default; perturbed estimates, torque limits, noise on every measurement),
``--duration`` s each.

* **One by one**: each case through ``simulate`` (its loop and its after-run signals, the
  summary's ``wall_time_s``), with a campaign worker's memory chunk.
* **Lock-step**: the cases through ``simulate_lockstep`` (the loop and every case's after-run
  signals), the same chunk.
* The bare Python plant loop of the performance issue (``bench_run.py``'s), same steps.

Checked and printed: every recorded signal of every case, lock-step against one by one (bit
for bit, or the signals that differ). Printed: us per case-step, the median over ``--repeat``
rounds (one by one and lock-step in turn), and the ratios to the bare loop.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import checkout  # noqa: E402

from ffsm_pin.sim.lockstep import simulate_lockstep  # noqa: E402
from ffsm_pin.sweep.worker import CASE_MEMORY_BYTES  # noqa: E402


def cases(scenario: str, batch: int, duration: float, controller: str = "lu-jia") -> list:
    """The scenarios of the first ``batch`` ``controller`` cases of ``scenario`` in
    compare-controllers."""
    from bench_step_parts import campaign_cases

    from ffsm_pin.scenario.file import scenario_from_toml

    found = campaign_cases(scenario, controller, batch)
    return [
        dataclasses.replace(scenario_from_toml(c.scenario_toml), duration=duration) for c in found
    ]


def prepared(scenarios) -> list:
    from ffsm_pin.sim.run import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [prepare(sc) for sc in scenarios]


def one_by_one(scenarios) -> tuple[float, int, list]:
    """(seconds, steps, results) of the cases run by ``simulate``, one after the other."""
    from ffsm_pin.sim.loop import simulate

    results = []
    for setup in prepared(scenarios):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results.append(simulate(setup, memory_bytes=CASE_MEMORY_BYTES))
    return sum(r.wall_time_s for r in results), sum(r.steps for r in results), results


def lockstep(scenarios) -> tuple[float, int, list]:
    """(seconds, steps, results) of the cases run by ``simulate_lockstep``."""
    setups = prepared(scenarios)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = simulate_lockstep(setups, memory_bytes=CASE_MEMORY_BYTES)
    return time.perf_counter() - t0, sum(r.steps for r in results), results


def compare(alone, together) -> str:
    """How many cases are equal bit for bit in every signal; the signals that differ."""
    equal, differ = 0, set()
    for one, lock in zip(alone, together, strict=True):
        bad = {k for k in one.signals
               if not np.array_equal(np.asarray(one.signals[k]), np.asarray(lock.signals[k]),
                                     equal_nan=True)}  # fmt: skip
        equal += not bad and one.stop_reason == lock.stop_reason
        differ |= bad
    text = f"{equal} of {len(alone)} cases bit for bit equal in every signal"
    return text if not differ else f"{text}; differ: {sorted(differ)}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--scenario", default="case1", choices=["case1", "planar5", "spatial-realistic"]
    )
    ap.add_argument("--controller", default="lu-jia", choices=["lu-jia", "gjm-ct", "adaptive-ct"])
    ap.add_argument("--batch", type=int, default=8, help="cases (default 8)")
    ap.add_argument("--duration", type=float, default=5.0, help="simulated s per case")
    ap.add_argument("--repeat", type=int, default=3, help="rounds (default 3)")
    a = ap.parse_args()
    from bench_run import bare_loop

    scenarios = cases(a.scenario, a.batch, a.duration, a.controller)
    lockstep([dataclasses.replace(sc, duration=0.05) for sc in scenarios[:2]])  # compile
    one, lock, bare = [], [], []
    check = ""
    for _ in range(a.repeat):
        wall, steps, alone = one_by_one(scenarios)
        one.append(wall / steps)
        wall, steps, together = lockstep(scenarios)
        lock.append(wall / steps)
        check = compare(alone, together)
        b = bare_loop(a.scenario, a.duration)
        bare.append(b["python_wall_time_s"] / b["steps"])
    py = statistics.median(bare) * 1e6
    o, k = statistics.median(one) * 1e6, statistics.median(lock) * 1e6
    print(f"ffsm-pin lock-step runs: {checkout(ROOT)}, load {os.getloadavg()[0]:.1f}")
    print(f"{a.batch} {a.scenario} {a.controller} cases of compare-controllers, "
          f"{a.duration} s each, {a.repeat} rounds; us per case-step (loop and after-run "
          "signals), median")  # fmt: skip
    print(f"  one by one (simulate)          {o:7.2f}  {o / py:5.2f}x the bare Python loop")
    print(f"  lock-step (simulate_lockstep)  {k:7.2f}  {k / py:5.2f}x the bare Python loop")
    print(f"  lock-step / one by one         {k / o:7.3f}")
    print(f"  bare Python loop               {py:7.2f}")
    print(f"  results: {check}")


if __name__ == "__main__":
    main()
