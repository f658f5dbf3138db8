"""What stepping a batch's plants at once would save: Pinocchio's ``abaInParallel`` on B states
against B calls of ``pin.aba``, per state, beside the whole step of a run.

Issue 38 asks whether the cases of a campaign batch could run in lock step, "the plant stepped
for all of them at once (Pinocchio's ``ModelPool`` / ``abaInParallel``)". The forward dynamics
is the one part of a plant step Pinocchio 4 offers for many states in one call (there is no
batched ``integrate`` or centroidal map): this measures what that call saves per state and
step, on one thread (a campaign runs one worker per core), for the paper's robot (case 1) and
the Panda on a satellite (``spatial``), at their initial states with small joint rates. The
same run also times ``Plant.advance`` (the package's whole plant step) for scale, and checks
how far ``abaInParallel``'s accelerations are from ``pin.aba``'s (another ABA variant: not the
same bits, so lock-step runs would match single runs only to rounding).

    python benchmarks/bench_batch_plant.py [--batch 1 8 32] [--repeat 7]

Printed per robot and batch size: the medians [us per state] of both, their difference, and
the largest difference of the accelerations relative to their largest entry.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
from _timing import checkout, time_interleaved

from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.run import prepare

ROOT = Path(__file__).resolve().parents[1]


def row(setup, size: int, repeat: int) -> tuple[float, float, float, float]:
    """(abaInParallel, pin.aba loop, Plant.advance) medians [us per state] and the largest
    relative difference of their accelerations, for ``size`` states of ``setup``'s robot."""
    model = setup.robot.model
    data = model.createData()
    plant = Plant(setup.robot)
    plant.reset(setup.q0, setup.v0)
    nb = plant.n_base
    u = np.zeros(model.nv - nb)
    q = np.tile(setup.q0[:, None], (1, size))
    v = np.tile(setup.v0[:, None], (1, size))
    v[nb:] += 0.01 * np.random.default_rng(size).standard_normal((model.nv - nb, size))
    tau = np.zeros((model.nv, size))
    a = np.zeros((model.nv, size))
    pool = pin.ModelPool(model, 1)
    columns = [(np.ascontiguousarray(q[:, i]), np.ascontiguousarray(v[:, i])) for i in range(size)]
    zero = np.zeros(model.nv)

    def batched() -> None:
        pin.abaInParallel(1, pool, q, v, tau, a)

    def one_by_one() -> None:
        for qi, vi in columns:
            pin.aba(model, data, qi, vi, zero)

    def advance() -> None:
        plant.advance(setup.q0, setup.v0, u, setup.scenario.dt)

    t = time_interleaved({"pool": batched, "loop": one_by_one, "plant": advance}, repeat=repeat)
    batched()
    ref = np.stack([pin.aba(model, data, qi, vi, zero).copy() for qi, vi in columns], 1)
    diff = float(np.max(np.abs(a - ref)) / np.max(np.abs(ref)))
    return t["pool"].median_us / size, t["loop"].median_us / size, t["plant"].median_us, diff


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--batch", type=int, nargs="+", default=[1, 8, 32])
    parser.add_argument("--repeat", type=int, default=7, help="samples per row")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"ffsm-pin batched plant benchmark: {checkout(ROOT)}, python {sys.version.split()[0]}, "
          f"pinocchio {pin.__version__}, {os.cpu_count()} CPU(s), load {load[0]:.2f}")  # fmt: skip
    print(f"{'case':10s} {'nv':>3s} {'B':>3s} {'abaInParallel':>14s} {'pin.aba':>9s} "
          f"{'saved':>7s} {'Plant.advance':>14s} {'rel. diff':>10s}   [us per state]")  # fmt: skip
    for case in ("case1", "spatial"):
        setup = prepare(builtin_scenario(case))
        nv = setup.robot.model.nv
        for size in args.batch:
            pool, loop, plant, diff = row(setup, size, args.repeat)
            print(f"{case:10s} {nv:3d} {size:3d} {pool:14.2f} {loop:9.2f} {loop - pool:7.2f} "
                  f"{plant:14.2f} {diff:10.1e}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
