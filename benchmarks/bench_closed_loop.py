"""Closed-loop step on the paper robot: plant + full adaptive controller, side by side.

    python benchmarks/bench_closed_loop.py [--repeat N] [--target-ms X] [--full-run]

Rows, all timed in the same run, sampled round-robin (see ``_timing.py``):

* the bare plant step (ABA + semi-implicit Euler + momentum projection) = the baseline;
* one closed-loop step, compiled controller (numba backend): measurement (Pinocchio
  kinematics), controller period, plant step;
* the same step with the numpy reference controller (the straightforward port);
* the controller period alone, for both backends.

The state is the paper's case 1 (built-in scenario ``case1``) after 2 s of closed loop, so
the estimators are mid-adaptation. The controller's states are restored before every call,
so each call does the same work. ``--full-run`` also times the whole 30 s case through
``simulate`` (with recording of every step) for each backend.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import time_interleaved  # noqa: E402

from ffsm_pin.scenario.file import builtin_scenario  # noqa: E402
from ffsm_pin.sim.plant import Plant  # noqa: E402
from ffsm_pin.sim.run import Sensor, prepare, simulate  # noqa: E402

TARGET_US = 100.0  # issue 3: median closed-loop step on this machine


def _state_after(setup, seconds: float):
    """Advance the closed loop ``seconds`` and return (q, v, t)."""
    ctrl = setup.controller.law  # the paper's law itself: step(meas, dt)
    sensor = Sensor(setup.robot, setup.model, full_model=False)
    plant = Plant(setup.robot)
    q, v = setup.q0.copy(), setup.v0.copy()
    plant.reset(q, v)
    dt = setup.scenario.dt
    for k in range(int(round(seconds / dt))):
        out = ctrl.step(sensor.measure(k * dt, q, v), dt)
        q, v, _ = plant.step(q, v, out.u_m, dt)
    return q, v, seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=31)
    parser.add_argument("--target-ms", type=float, default=4.0)
    parser.add_argument("--full-run", action="store_true", help="also time the 30 s case")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")

    setups = {}
    for backend in ("numba", "numpy"):
        setup = prepare(builtin_scenario("case1"))
        if backend == "numpy":
            setup.controller.law.backend = "numpy"
        setups[backend] = setup
    q, v, t = _state_after(setups["numba"], 2.0)
    _state_after(setups["numpy"], 2.0)  # same estimator states (to 1e-12)
    dt = setups["numba"].scenario.dt
    plant = Plant(setups["numba"].robot)
    plant.reset(setups["numba"].q0, setups["numba"].v0)
    sensor = Sensor(setups["numba"].robot, setups["numba"].model, full_model=False)
    meas = sensor.measure(t, q, v)
    u0 = setups["numba"].controller.law.step(meas, dt).u_m

    fns = {"plant step (baseline)": lambda: plant.step(q, v, u0, dt)}
    for backend, setup in setups.items():
        ctrl = setup.controller.law
        saved = copy.deepcopy((ctrl.theta_z, ctrl.theta_d, ctrl.theta_b, ctrl.w_hat, ctrl.Y_df))

        def restore(ctrl=ctrl, saved=saved):
            for name, value in zip(
                ("theta_z", "theta_d", "theta_b", "w_hat", "Y_df"), saved, strict=True
            ):
                getattr(ctrl, name)[...] = value

        def controller_only(ctrl=ctrl, restore=restore):
            restore()
            return ctrl.step(meas, dt)

        def closed_loop(ctrl=ctrl, restore=restore):
            restore()
            m = sensor.measure(t, q, v)
            return plant.step(q, v, ctrl.step(m, dt).u_m, dt)

        fns[f"closed-loop step, {backend} controller"] = closed_loop
        fns[f"controller period only, {backend}"] = controller_only
    fns["restore of the estimator states (overhead)"] = lambda: None
    times = time_interleaved(fns, repeat=args.repeat, target_s=args.target_ms * 1e-3)

    base = times["plant step (baseline)"].median_us
    print(f"paper robot, case 1 state at t = {t:.1f} s, dt = {dt} s; medians of {args.repeat}")
    print(f"{'row':48s} {'median us':>10s} {'q1-q3':>15s} {'x plant step':>13s}")
    print("-" * 90)
    for name, tm in times.items():
        print(
            f"{name:48s} {tm.median_us:10.2f} {tm.q1_us:7.2f}-{tm.q3_us:<7.2f} "
            f"{tm.median_us / base:12.2f}x"
        )
    fast = times["closed-loop step, numba controller"].median_us
    ref = times["closed-loop step, numpy controller"].median_us
    print("-" * 90)
    print(f"numpy / numba closed-loop step: {ref / fast:.1f}x")
    print(f"closed-loop step {fast:.1f} us vs target {TARGET_US:.0f} us: "
          f"{'met' if fast <= TARGET_US else 'NOT met'}")  # fmt: skip

    if args.full_run:
        for backend in ("numba", "numpy"):
            setup = prepare(builtin_scenario("case1"))
            if backend == "numpy":
                setup.controller.law.backend = "numpy"
            t0 = time.perf_counter()
            result = simulate(setup)
            wall = time.perf_counter() - t0
            s = result.summary()
            print(
                f"30 s case 1, {backend}: {wall:.2f} s wall ({result.steps} steps, "
                f"{wall / result.steps * 1e6:.0f} us/step incl. recording), "
                f"funnels kept: {s['funnel_ok_b'] and s['funnel_ok_z']}, "
                f"final |err_z| {np.linalg.norm(s['final_err_z']):.2e}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
