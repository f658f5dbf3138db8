"""The paper's case 1 from Python: run it, print what it kept, draw its figures.

python examples/case1.py                   # 30 s, the paper's horizon
python examples/case1.py --duration 3      # a short look
"""

import argparse
import dataclasses

from ffsm_pin import builtin_scenario, prepare, simulate
from ffsm_pin.sim.figures import write_figures

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--duration", type=float, default=30.0, help="simulated time [s]")
parser.add_argument("--out", default="runs/example-case1", help="output folder")
args = parser.parse_args()

scenario = dataclasses.replace(builtin_scenario("case1"), duration=args.duration)
result = simulate(prepare(scenario))  # prepare() checks everything that can fail before a run
summary = result.save(args.out)  # trajectory.npz and summary.json
paths = write_figures(result, args.out)  # the paper's figures: errors, velocities, estimates...

print(f"completed: {summary['completed']}, funnels kept (b / z): "
      f"{summary['funnel_ok_b']} / {summary['funnel_ok_z']}")  # fmt: skip
print(f"final end-effector error [m, m, rad]: {summary['final_err_z']}")
print(f"momentum drift: |P - P0| = {summary['drift_P']:.2e}, |L - L0| = {summary['drift_L']:.2e}")
print("figures:", ", ".join(p.name for p in paths))
