"""A capture run's target: the torque-free step compiled against its numpy reference, alone and
in a whole `capture-approach` run, side by side in one process.

Usage::

    python benchmarks/bench_target.py                  # 3 s of capture-approach, 5 rounds
    python benchmarks/bench_target.py --duration 6 --rounds 7

* ``torque_free_step``: one 2 ms step of the case's box, ``compiled=False`` (the numpy
  reference) against ``compiled=True`` (``ffsm_pin/sim/_target_kernels.py``), sampled
  round-robin (``_timing.time_interleaved``); both give the same bits here (checked).
* A whole run of ``capture-approach`` (the target stepped every plant step and predicted over
  the target sensor's delay every control period), the run's default (compiled) against the
  reference (``ffsm_pin.sim.target.numba_available`` patched to False), alternating, per-step
  medians and their ratio; the two runs' trajectories are checked equal.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
import warnings
from pathlib import Path

import numpy as np
from _timing import checkout, time_interleaved

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=3.0, help="simulated seconds a run")
    parser.add_argument("--rounds", type=int, default=5, help="runs of each side")
    args = parser.parse_args()

    import ffsm_pin.sim.target as target_module
    from ffsm_pin import prepare, simulate
    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.target import torque_free_step

    warnings.simplefilter("ignore")
    sc = dataclasses.replace(builtin_scenario("capture-approach"), duration=args.duration)
    setup = prepare(sc)
    box, state = setup.target, setup.target_state
    a = torque_free_step(box, state, 0.002, compiled=True)
    b = torque_free_step(box, state, 0.002, compiled=False)
    same = a.pose.rotation.tobytes() == b.pose.rotation.tobytes()
    step = time_interleaved(
        {
            "numpy": lambda: torque_free_step(box, state, 0.002, compiled=False),
            "compiled": lambda: torque_free_step(box, state, 0.002, compiled=True),
        }
    )
    print(f"{checkout(ROOT)}; load {Path('/proc/loadavg').read_text().split()[0]}")
    print(f"torque_free_step [us], median (q1 .. q3); same bits: {same}")
    for name, t in step.items():
        print(f"  {name:9s} {t.median_us:8.2f} ({t.q1_us:.2f} .. {t.q3_us:.2f})")
    print(f"  numpy / compiled {step['numpy'].median_us / step['compiled'].median_us:.2f}x")

    original = target_module.numba_available
    per_step: dict[str, list[float]] = {"compiled": [], "numpy": []}
    last: dict[str, np.ndarray] = {}
    simulate(prepare(dataclasses.replace(sc, duration=0.1)))  # (compiles what runs)
    for _ in range(args.rounds):
        for name in per_step:
            target_module.numba_available = original if name == "compiled" else (lambda: False)
            run_setup = prepare(sc)
            t0 = time.perf_counter()
            result = simulate(run_setup)
            per_step[name].append((time.perf_counter() - t0) / len(result["t"]) * 1e6)
            last[name] = np.asarray(result["q"])
    target_module.numba_available = original
    print(f"capture-approach, {args.duration:g} s, {args.rounds} runs a side [us a step]")
    for name, samples in per_step.items():
        print(
            f"  {name:9s} median {statistics.median(samples):8.1f}  samples "
            + " ".join(f"{s:.1f}" for s in samples)
        )
    ratio = statistics.median(per_step["numpy"]) / statistics.median(per_step["compiled"])
    equal = last["compiled"].tobytes() == last["numpy"].tobytes()
    print(f"  numpy / compiled {ratio:.2f}x; trajectories bit for bit equal: {equal}")


if __name__ == "__main__":
    main()
