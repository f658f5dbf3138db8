"""Where a whole run's step goes: each stage of the run loop timed inside a real run, beside the
bare plant loop on the same robot.

Usage::

    python benchmarks/bench_step_parts.py                    # case1, spatial-realistic x lu-jia
    python benchmarks/bench_step_parts.py --controllers lu-jia gjm-ct adaptive-ct --repeat 3
    python benchmarks/bench_step_parts.py --scale 1          # the campaign's full durations

A row is a case of the shipped campaign ``compare-controllers`` (its first non-nominal case of
that scenario and controller: perturbed estimates, torque limits, sensor noise), so what is
measured is a campaign case's loop (``python -m ffsm_pin.sweep``'s worker runs it the same
way, :func:`ffsm_pin.sweep.engine.run_case`), with its duration times ``--scale``. Each row
runs in a fresh process (this script with ``--row``): a warm-up run (numba's cache loaded),
then

* the run as a campaign runs it, nothing wrapped: its loop's time per step (``wall_time_s`` /
  ``steps``, the after-run signals included, as the run reports it);
* the same case again with each stage of :func:`ffsm_pin.sim.loop.simulate` wrapped in a
  timer (``time.perf_counter`` around the call): the controller's ``step`` (for the shipped
  controllers their compiled period), the plant (``Plant.advance``: ABA, integrate, momentum
  projection), the exact measurement (``Sensor.measure``: Pinocchio's kinematics), the
  sensors' noise (``Sensors.observe``), the actuators (``Actuators.apply``), the checks of
  the torque and of the state, the reply's split, the base acceleration for F_r, the
  recorder's commit and the after-run signals (momentum rows, F_r). ``loop glue`` is the
  wrapped run's loop time less its stages: the loop's own lines (recording a row, the stop
  checks). The wrapped run is slower by the timers themselves (``timer overhead``: the wrapped
  run's time per step less the plain run's; about 0.1 us per wrapped call, in the stages);
* the bare plant loop (``bench_run.py``'s: the package's plant stepped with zero torque) and
  the performance issue's bare Python loop, for the same steps from the same state.

Printed per row: each stage's median time per step over the rounds [us], its share of the
plain run's step, and the plain run against the bare Python loop (the issue's ratio).
Rounds run the rows in turn (a change of machine load hits every row alike); the first round
is not discarded (each process warms up on its own).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import checkout  # noqa: E402

#: The stages, as (label, module, class or None, attribute) of what is wrapped.
STAGES = [
    ("controller step", None, None, "step"),  # the controller instance's own
    ("plant", "ffsm_pin.sim.plant", "Plant", "advance"),
    ("measurement", "ffsm_pin.sim.measurement", "Sensor", "measure"),
    ("sensor noise", "ffsm_pin.sim.sensors", "Sensors", "observe"),
    ("actuators", "ffsm_pin.sim.actuators", "Actuators", "apply"),
    ("torque check", "ffsm_pin.sim.loop", None, "checked_torque"),
    ("state check", "ffsm_pin.sim.plant", "Plant", "state_status"),
    ("reply split", "ffsm_pin.sim.loop", None, "split_reply"),
    ("base acceleration", "ffsm_pin.sim.measurement", "Sensor", "base_angular_acceleration"),
    ("recorder commit", "ffsm_pin.sim.recorder", "Recorder", "commit"),
    ("after-run signals", "ffsm_pin.sim.loop", None, "system_signals"),
]


def campaign_cases(scenario: str, controller: str, count: int = 1) -> list:
    """The first ``count`` non-nominal cases of ``compare-controllers`` for that scenario and
    controller (also ``bench_lockstep.py``'s)."""
    from ffsm_pin.sweep.campaign import load_campaign
    from ffsm_pin.sweep.cases import expand

    found = [
        case
        for case in expand(load_campaign("compare-controllers"))
        if not case.nominal
        and (case.values.get("scenario"), case.values.get("controller.type"))
        == (scenario, controller)
    ][:count]
    if len(found) < count:
        raise SystemExit(
            f"compare-controllers has {len(found)} cases of {scenario} x {controller}, not {count}"
        )
    return found


def run(scenario, wrap: bool) -> dict:
    """One run of the case's ``scenario`` as a campaign's worker runs it; with ``wrap``, each
    stage timed."""
    import importlib

    from ffsm_pin.sim.run import prepare, simulate
    from ffsm_pin.sweep.engine import CASE_MEMORY_BYTES

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(scenario)
    spent = dict.fromkeys((label for label, *_ in STAGES), 0.0)
    undo = []
    if wrap:
        clock = time.perf_counter

        def timed(fn, label):
            def call(*args, **kwargs):
                t0 = clock()
                out = fn(*args, **kwargs)
                spent[label] += clock() - t0
                return out

            return call

        for label, module, cls, attr in STAGES:
            owner = setup.controller if module is None else importlib.import_module(module)
            owner = owner if cls is None else getattr(owner, cls)
            original = getattr(owner, attr)
            setattr(owner, attr, timed(original, label))
            undo.append((owner, attr, original, module is None))
    try:
        result = simulate(setup, memory_bytes=CASE_MEMORY_BYTES)
    finally:
        for owner, attr, original, instance in undo:
            if instance:
                delattr(owner, attr)  # (the class's method again)
            else:
                setattr(owner, attr, original)
    steps = max(1, result.steps)
    return {"loop": result.wall_time_s / steps, **{k: v / steps for k, v in spent.items()}}


def measure_row(scenario: str, controller: str, scale: float) -> dict:
    """The row's numbers [s per step] (this script with ``--row``, in a fresh process)."""
    import dataclasses

    from bench_run import bare_loop

    from ffsm_pin.scenario.file import scenario_from_toml

    sc = scenario_from_toml(campaign_cases(scenario, controller)[0].scenario_toml)
    duration = sc.duration * scale
    run(dataclasses.replace(sc, duration=1.0), wrap=False)  # warm-up: numba's cache loaded
    scaled = dataclasses.replace(sc, duration=duration)
    plain = run(scaled, wrap=False)
    wrapped = run(scaled, wrap=True)
    bare = bare_loop(scenario, duration)
    steps = bare["steps"]
    stages = {k: v for k, v in wrapped.items() if k != "loop"}
    return {
        "plain": plain["loop"], "wrapped": wrapped["loop"], "stages": stages,
        "glue": wrapped["loop"] - sum(stages.values()),
        "plant_loop": bare["wall_time_s"] / steps, "py_loop": bare["python_wall_time_s"] / steps,
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["case1", "spatial-realistic"])
    ap.add_argument("--controllers", nargs="+", default=["lu-jia"])
    ap.add_argument("--repeat", type=int, default=3, help="rounds (default 3)")
    ap.add_argument("--scale", type=float, default=0.25, help="times the case's duration")
    ap.add_argument("--row", nargs=2, metavar=("SCENARIO", "CONTROLLER"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.row:
        print(json.dumps(measure_row(*a.row, a.scale)))
        return
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    rows = [(s, c) for s in a.cases for c in a.controllers]
    samples: dict[tuple, list[dict]] = {row: [] for row in rows}
    for _ in range(a.repeat):
        for row in rows:
            cmd = [sys.executable, __file__, "--row", *row, "--scale", str(a.scale)]
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
            if proc.returncode != 0:
                raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr}")
            samples[row].append(json.loads(proc.stdout.strip().splitlines()[-1]))
    load = os.getloadavg()[0]
    print(f"ffsm-pin step-parts benchmark: {checkout(ROOT)}, python {sys.version.split()[0]}, "
          f"load {load:.1f}; {a.repeat} rounds, durations x {a.scale}")  # fmt: skip
    print("us per step: median over rounds; share = of the plain run's step")

    def med(row, get) -> float:
        return statistics.median(get(s) for s in samples[row]) * 1e6

    for row in rows:
        plain = med(row, lambda s: s["plain"])
        py = med(row, lambda s: s["py_loop"])
        print(f"{row[0]} x {row[1]} (compare-controllers case):")
        print(
            f"  {'run, plain':24s} {plain:8.2f}  100.0%  ({plain / py:.2f}x the bare Python loop)"
        )
        parts = [(k, med(row, lambda s, k=k: s["stages"][k])) for k in samples[row][0]["stages"]]
        parts.append(("loop glue", med(row, lambda s: s["glue"])))
        for label, us in sorted(parts, key=lambda p: -p[1]):
            print(f"  {label:24s} {us:8.2f}  {100 * us / plain:5.1f}%")
        wrapped = med(row, lambda s: s["wrapped"])
        print(f"  {'timer overhead':24s} {wrapped - plain:8.2f}  (wrapped run {wrapped:.2f})")
        print(f"  {'bare plant loop':24s} {med(row, lambda s: s['plant_loop']):8.2f}")
        print(f"  {'bare Python loop':24s} {py:8.2f}")


if __name__ == "__main__":
    main()
