"""Cost of the null-space option: compiled closed-loop step on the 5-link robot, side by side.

    python benchmarks/bench_null_space.py [--repeat N] [--target-ms X]

Rows, all timed in the same run, sampled round-robin (see ``_timing.py``), on the built-in
scenario ``planar5`` after 2 s of closed loop (numba backend):

* the bare plant step = the baseline;
* the closed-loop step (measurement, controller period, plant step) with the paper's law
  (objective "none") and with each objective ("manipulability" adds 2 m_1 evaluations of
  J_m-hat U-hat and a determinant per period, inside the complex-step evaluation).

The controller's states are restored before every call, so each call does the same work.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import time_interleaved  # noqa: E402

from ffsm_pin.control.null_space import NullSpace  # noqa: E402
from ffsm_pin.scenario.file import builtin_path, load_scenario  # noqa: E402
from ffsm_pin.sim.plant import Plant  # noqa: E402
from ffsm_pin.sim.run import Sensor, prepare  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OBJECTIVES = ("none", "manipulability", "joint-centering")


def _planar5(objective: str):
    sc = load_scenario(builtin_path("planar5"))
    urdf = REPO / "urdf" / "ffsm_planar5.urdf"  # the repository's copy (see docs/null_space.md)
    robot = dataclasses.replace(sc.robot, urdf=str(urdf)) if urdf.is_file() else sc.robot
    lu_jia = dataclasses.replace(sc.controller.lu_jia, null_space=NullSpace(objective, 1.0))
    ctrl = dataclasses.replace(sc.controller, lu_jia=lu_jia)
    return dataclasses.replace(sc, robot=robot, controller=ctrl)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=31)
    parser.add_argument("--target-ms", type=float, default=4.0)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")

    setups = {obj: prepare(_planar5(obj)) for obj in OBJECTIVES}
    ref = setups["none"]
    dt = ref.scenario.dt
    sensor = Sensor(ref.robot, ref.model, full_model=False)
    plant = Plant(ref.robot)
    q, v = ref.q0.copy(), ref.v0.copy()
    plant.reset(q, v)
    law = ref.controller.law  # the paper's law itself: step(meas, dt)
    for k in range(2000):  # 2 s of the paper's law: estimators mid-adaptation
        q, v, _ = plant.step(q, v, law.step(sensor.measure(k * dt, q, v), dt).u_m, dt)
    t = 2000 * dt
    u0 = law.step(sensor.measure(t, q, v), dt).u_m

    fns = {"plant step (baseline)": lambda: plant.step(q, v, u0, dt)}
    for obj, setup in setups.items():
        ctrl = setup.controller.law  # the paper's law itself: step(meas, dt)
        assert ctrl.backend == "numba"
        for name in ("theta_z", "theta_d", "theta_b", "w_hat", "Y_df"):  # the same state
            getattr(ctrl, name)[...] = getattr(law, name)
        saved = copy.deepcopy((ctrl.theta_z, ctrl.theta_d, ctrl.theta_b, ctrl.w_hat, ctrl.Y_df))

        def closed_loop(ctrl=ctrl, saved=saved):
            for name, value in zip(
                ("theta_z", "theta_d", "theta_b", "w_hat", "Y_df"), saved, strict=True
            ):
                getattr(ctrl, name)[...] = value
            m = sensor.measure(t, q, v)
            return plant.step(q, v, ctrl.step(m, dt).u_m, dt)

        fns[f"closed-loop step, objective {obj!r}"] = closed_loop
    times = time_interleaved(fns, repeat=args.repeat, target_s=args.target_ms * 1e-3)

    base = times["plant step (baseline)"].median_us
    paper = times["closed-loop step, objective 'none'"].median_us
    print(f"planar5 (5 joints), state at t = {t:.1f} s, dt = {dt} s; medians of {args.repeat}")
    print(f"{'row':48s} {'median us':>10s} {'q1-q3':>15s} {'x plant':>8s} {'x none':>7s}")
    print("-" * 92)
    for name, tm in times.items():
        print(
            f"{name:48s} {tm.median_us:10.2f} {tm.q1_us:7.2f}-{tm.q3_us:<7.2f} "
            f"{tm.median_us / base:7.2f}x {tm.median_us / paper:6.2f}x"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
