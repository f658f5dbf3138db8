"""Numbers of docs/robust.md: ``adaptation = "gradient"`` against ``"physical"`` on case 1 as the
compare-controllers campaign runs it (100 N m torque limits, sensor noise, physical draws of the
initial estimates within ``--spread``), for the lu-jia and adaptive-ct controllers.

Prints one row per (controller, adaptation, seed): completed, the stop (cut), end-effector funnel
kept, lambda_min(P(theta_d-hat)) over the run against eps (the derived margin, 0.1 x that of
the initial estimate), the recorded steps at the margin (< 1.001 eps: the projection acted),
|theta_d-hat - theta_d| at the start and its largest value, and the run's wall time.

    python docs/robust_numbers.py                        # seeds 0-19, spread 0.3, 30 s
    python docs/robust_numbers.py --seeds 2 6 --controllers lu-jia --duration 15
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import tomllib

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from ffsm_pin.scenario.file import builtin_path, scenario_from_dict  # noqa: E402
from ffsm_pin.sim.run import prepare, simulate  # noqa: E402

NOISE = dict(joints=1e-4, joint_rates=1e-3, base_attitude=1e-4, base_rate=1e-3, ee_pose=1e-3,
             ee_velocity=1e-3)  # fmt: skip


def scenario(ctype: str, adaptation: str, seed: int, spread: float, duration: float):
    """Case 1 with the campaign's limits and noise, the controller and the estimates' draw."""
    doc = copy.deepcopy(tomllib.loads(builtin_path("case1").read_text()))
    doc["controller"].update(type=ctype, adaptation=adaptation)
    doc["controller"]["estimates"] = {"initial": "perturbed", "spread": spread, "seed": seed}
    doc["actuators"] = {"torque_limit": 100.0}
    doc["sensors"] = {"seed": 7, "noise": NOISE}
    doc["sim"]["duration"] = duration
    return scenario_from_dict(doc)


def row(args: tuple) -> str:
    ctype, adaptation, seed, spread, duration = args
    warnings.simplefilter("ignore")
    start = time.perf_counter()
    setup = prepare(scenario(ctype, adaptation, seed, spread, duration))
    res = simulate(setup)
    wall = time.perf_counter() - start
    m = setup.model
    theta = np.asarray(res["theta_d_hat"])
    lam = np.array([np.linalg.eigvalsh(m.pseudo_inertia(x))[0] for x in theta])
    eps = 0.1 * lam[0]
    dist = np.linalg.norm(theta - res["theta_d"], axis=1)
    stop = "" if res.completed else (res.stop_reason or "").split(": ", 1)[-1][:48]
    return (f"{ctype:11s} {adaptation:8s} {seed:4d} {str(res.completed):5s} "
            f"{str(res.summary()['funnel_ok_z']):5s} {lam.min() / eps:10.3g} "
            f"{int(np.sum(lam < 1.001 * eps)):6d} {dist[0]:6.2f} {dist.max():9.3g} "
            f"{wall:6.1f}  {stop}")  # fmt: skip


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=list(range(20)))
    p.add_argument("--spread", type=float, default=0.3)
    p.add_argument("--duration", type=float, default=30.0)
    p.add_argument("--controllers", nargs="+", default=["lu-jia", "adaptive-ct"])
    p.add_argument("--workers", type=int, default=2)
    a = p.parse_args()
    jobs = [(c, ad, s, a.spread, a.duration) for c in a.controllers
            for ad in ("gradient", "physical") for s in a.seeds]  # fmt: skip
    print("controller  law      seed done  z-ok  minlam/eps at-eps  |th~|0  max|th~|   wall  stop")
    with ProcessPoolExecutor(a.workers) as pool:
        for line in pool.map(row, jobs):
            print(line, flush=True)


if __name__ == "__main__":
    main()
