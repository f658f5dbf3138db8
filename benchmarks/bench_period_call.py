"""What the paper's controller costs a period around its compiled law, on a replay of a run.

A built-in case is run for ``--duration`` seconds (``simulate``), and the sensor's exact
measurement of every recorded state is kept. Each sample then replays those measurements,
period after period, through a controller prepared afresh for it (``prepare``: the same initial
estimates, so every sample does the same work along the same trajectory), timing one of:

* ``law.step``: :meth:`CoordinatedController.step`, the period with all its named outputs
  (:class:`~ffsm_pin.control.controller.ControlOutput`): the baseline of each case;
* ``controller.step``: :meth:`LuJiaController.step`, what the run loop calls, with
  :func:`~ffsm_pin.control.interface.split_reply` as the loop does (u_m and the signals' row).

Samples are taken round-robin (one per row per round), so a change of machine load hits both
rows alike; printed per case: the median us per period of each row over ``--repeat`` rounds,
and the ratio of the medians with the quartiles of the per-round ratios. Run it from another
checkout (``PYTHONPATH=...``) to compare revisions: the ratio within one run is what is
comparable across machines and loads.

Usage::

    python benchmarks/bench_period_call.py                      # case1 and spatial, 9 rounds
    python benchmarks/bench_period_call.py --cases case1 --duration 1 --repeat 15
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import checkout  # noqa: E402

import ffsm_pin  # noqa: E402
from ffsm_pin.control.interface import split_reply  # noqa: E402
from ffsm_pin.scenario.file import builtin_scenario  # noqa: E402
from ffsm_pin.sim.loop import simulate  # noqa: E402
from ffsm_pin.sim.measurement import Sensor  # noqa: E402
from ffsm_pin.sim.setup import prepare  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def measurements(scenario) -> list:
    """The exact measurement of every state of a run of ``scenario`` (copies)."""
    setup = prepare(scenario)
    signals = simulate(setup).signals
    sensor = Sensor(setup.robot, setup.model, full_model=False)
    q, v, t = signals["q"], signals["v"], signals["t"]
    return [sensor.measure(float(t[k]), q[k].copy(), v[k].copy()) for k in range(len(t))]


def replay(scenario, metas: list, row: str) -> float:
    """Seconds per period of one replay of ``metas`` through a fresh controller."""
    controller = prepare(scenario).controller
    law, dt = controller.law, scenario.dt
    t0 = time.perf_counter()
    if row == "law.step":
        for meas in metas:
            law.step(meas, dt)
    else:
        for meas in metas:
            split_reply(controller.step(meas))
    return (time.perf_counter() - t0) / len(metas)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=["case1", "spatial"])
    parser.add_argument("--duration", type=float, default=2.0, help="replayed seconds")
    parser.add_argument("--repeat", type=int, default=9, help="timed rounds (default 9)")
    args = parser.parse_args()
    package = Path(ffsm_pin.__file__).resolve().parent  # what is timed (PYTHONPATH may differ)
    here = f"{checkout(ROOT)}, " if package.parent == ROOT else ""
    print(f"ffsm-pin period-call benchmark: {here}ffsm_pin from {package}, "
          f"python {sys.version.split()[0]}")  # fmt: skip
    print("us per period: median over rounds; ratio = controller.step / law.step "
          "(per-round q1 .. q3)")  # fmt: skip
    rows = ("law.step", "controller.step")
    for case in args.cases:
        scenario = dataclasses.replace(builtin_scenario(case), duration=args.duration)
        metas = measurements(scenario)
        for row in rows:  # warm-up: load the kernels, fill the caches
            replay(scenario, metas[:50], row)
        times: dict[str, list[float]] = {row: [] for row in rows}
        for _ in range(args.repeat):
            for row in rows:
                times[row].append(replay(scenario, metas, row))
        base, ours = (statistics.median(times[row]) for row in rows)
        ratios = [b / a for a, b in zip(times[rows[0]], times[rows[1]], strict=True)]
        q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratios[0]] * 3
        print(f"{case:10s} {len(metas):6d} periods  law.step {base * 1e6:7.2f}  "
              f"controller.step {ours * 1e6:7.2f}  ratio {ours / base:.3f} "
              f"({q[0]:.3f} .. {q[2]:.3f})  difference {(ours - base) * 1e6:+.2f} us",
              flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
