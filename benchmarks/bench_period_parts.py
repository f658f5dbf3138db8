"""Where the paper's compiled control period spends its time: its three steps one by one.

:func:`ffsm_pin.control.period.period` runs three compiled steps per geometry (docs/
controllers.md): the geometry's terms and the estimates' laws (Eqs. 28, 42), the kinematic law
at complex arguments (Eqs. 25+36, its exact derivative by the complex step) and the dynamic
level (Eqs. 46, 49-52, 60-64). For each case this benchmark prepares the case's controller,
takes one period at the initial measurement (so that the kernels are loaded and the bundles
made), and times, each in a compiled loop of ``--number`` calls at that measurement (numba's
dispatch paid once per loop, not per call):

* ``geometry``: the geometry step;
* ``kinematic``: the kinematic law with the period's complex arguments built around it;
* ``dynamic``: the dynamic level, at the kinematic law's w_mc and its derivative;
* ``period, compiled loop``: the whole period;
* ``period, from Python``: the whole period called from Python once per period, as the
  controller does (:func:`~ffsm_pin.control.period.period_of` with the controller's box of
  the fixed arguments; the difference to the row above is numba's dispatch: typing and
  unboxing the box, the measurement and ``dt``, and boxing the result);
* ``period, bundles unboxed``: the same period called with the fixed arguments as separate
  bundles, as the controller called it before the box (numba unboxes each of their arrays per
  call; the box is then made in compiled code): the box's saving, side by side.

The state the period advances in place is the prepared controller's, copied afresh for every
sample. Samples are taken round-robin over the rows (``--repeat`` rounds), so a change of
machine load hits every row alike; printed per case: each row's median us per call, its
share of the compiled period, and the quartiles over rounds. The steps' sum is less than the
period: the period also writes its outputs and builds the complex arguments once more.

Usage::

    python benchmarks/bench_period_parts.py                  # case1 and spatial-realistic
    python benchmarks/bench_period_parts.py --cases spatial --repeat 9
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from _timing import checkout  # noqa: E402
from numba import njit  # noqa: E402

import ffsm_pin  # noqa: E402  (first: the package's numba settings)
from ffsm_pin.control._period_box import PeriodBox, period_box  # noqa: E402
from ffsm_pin.control.interface import Measurement  # noqa: E402
from ffsm_pin.control.kernels import COMPLEX_STEP  # noqa: E402
from ffsm_pin.control.period import (  # noqa: E402
    KernelGains,
    PeriodLaw,
    PeriodState,
    dynamic_level,
    geometry_terms,
    kinematic_law,
    period_of,
)
from ffsm_pin.control.reference_kernels import ReferenceArrays  # noqa: E402
from ffsm_pin.scenario.file import builtin_scenario  # noqa: E402
from ffsm_pin.sim.measurement import Sensor  # noqa: E402
from ffsm_pin.sim.setup import prepare  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ROWS = (
    "geometry", "kinematic", "dynamic", "period, compiled loop", "period, from Python",
    "period, bundles unboxed",
)  # fmt: skip


@njit(cache=True)
def _bundles(law_f, ref_f, meas_f, state_f):
    """The named bundles of the period's plain tuples (as :func:`period` names them)."""
    g = law_f[4]
    law = PeriodLaw(law_f[0], law_f[1], law_f[2], law_f[3], KernelGains(*g), law_f[5], law_f[6],
                    law_f[7], law_f[8], law_f[9], law_f[10], law_f[11])  # fmt: skip
    return law, ReferenceArrays(*ref_f), Measurement(*meas_f), PeriodState(*state_f)


@njit(cache=True)
def _complex_law(geo, law, ref, dt, meas, state, tb_new, tz_new, q_b_rate, w_b):
    """The kinematic law at the period's complex arguments, built from the geometry step's
    outputs (as :func:`period` builds and calls them)."""
    n = meas.q_m.size
    w = meas.w
    hj = 1j * COMPLEX_STEP
    theta_b, theta_z = state.theta_b, state.theta_z
    q_c, q_m_c = meas.q_b + hj * q_b_rate, meas.q_m + hj * w[w.size - n :]
    tb_c, tz_c = theta_b + hj * (tb_new - theta_b) / dt, theta_z + hj * (tz_new - theta_z) / dt
    return kinematic_law(geo, law, ref, law.null_space, meas.t + hj, q_c, q_m_c,
                         meas.z_e + hj * meas.z_e_dot, tb_c, tz_c, w_b + 0j)  # fmt: skip


@njit(cache=True)
def time_geometry(geo, law_f, ref_f, dt, meas_f, state_f, number):
    law, ref, meas, state = _bundles(law_f, ref_f, meas_f, state_f)
    acc = 0.0
    for _ in range(number):
        acc += geometry_terms(geo, law, dt, meas, state)[1][0]
    return acc


@njit(cache=True)
def time_kinematic(geo, law_f, ref_f, dt, meas_f, state_f, number):
    law, ref, meas, state = _bundles(law_f, ref_f, meas_f, state_f)
    terms, tb_new, tz_new, q_b_rate, w_b = geometry_terms(geo, law, dt, meas, state)
    acc = 0.0
    for _ in range(number):
        acc += _complex_law(geo, law, ref, dt, meas, state, tb_new, tz_new, q_b_rate, w_b)[2]
    return acc


@njit(cache=True)
def time_dynamic(geo, law_f, ref_f, dt, meas_f, state_f, number):
    law, ref, meas, state = _bundles(law_f, ref_f, meas_f, state_f)
    terms, tb_new, tz_new, q_b_rate, w_b = geometry_terms(geo, law, dt, meas, state)
    w_mc_c, sens = _complex_law(geo, law, ref, dt, meas, state, tb_new, tz_new, q_b_rate, w_b)[:2]
    w_mc = w_mc_c.real.copy()
    w_mc_dot = w_mc_c.imag / COMPLEX_STEP
    sens = np.ascontiguousarray(sens)
    acc = 0.0
    for _ in range(number):
        acc += dynamic_level(geo, terms, law, dt, meas, w_mc, w_mc_dot, sens, state)[1]
    return acc


@njit(cache=True)
def time_period(box, dt, meas_f, number):
    acc = 0.0
    for _ in range(number):
        acc += period_of(box, dt, meas_f, None)[2]
    return acc


@njit(cache=True)
def period_unboxed(geo, law_f, ref_f, dt, meas_f, state_f, out_f, aux):
    """The period called with its bundles as separate arguments (as before the box): numba
    unboxes every array of them per call; the box is made in compiled code."""
    return period_of(PeriodBox(geo, law_f, ref_f, state_f, out_f), dt, meas_f, aux)


def sample(row: str, args, number: int) -> float:
    """Seconds per call of ``row`` over ``number`` calls, on a fresh copy of the state."""
    geo, law, ref, dt, meas, state, out, aux = args
    state = tuple(x.copy() for x in state)
    box = period_box(geo, law, ref, state, out)
    t0 = time.perf_counter()
    if row == "geometry":
        time_geometry(geo, law, ref, dt, meas, state, number)
    elif row == "kinematic":
        time_kinematic(geo, law, ref, dt, meas, state, number)
    elif row == "dynamic":
        time_dynamic(geo, law, ref, dt, meas, state, number)
    elif row == "period, compiled loop":
        time_period(box, dt, meas, number)
    elif row == "period, from Python":
        for _ in range(number):
            period_of(box, dt, meas, aux)
    else:
        for _ in range(number):
            period_unboxed(geo, law, ref, dt, meas, state, out, aux)
    return (time.perf_counter() - t0) / number


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=["case1", "spatial-realistic"])
    parser.add_argument("--number", type=int, default=1000, help="calls per sample")
    parser.add_argument("--repeat", type=int, default=7, help="timed rounds (default 7)")
    args = parser.parse_args()
    package = Path(ffsm_pin.__file__).resolve().parent
    here = f"{checkout(ROOT)}, " if package.parent == ROOT else ""
    print(f"ffsm-pin period-parts benchmark: {here}ffsm_pin from {package}, "
          f"python {sys.version.split()[0]}")  # fmt: skip
    print("us per call: median over rounds (q1 .. q3); share = of the compiled loop's period")
    for case in args.cases:
        setup = prepare(builtin_scenario(case))
        if setup.scenario.controller.type != "lu-jia" or setup.controller.law.auxiliary is not None:
            print(f"{case}: not the paper's law with its own period; skipped")
            continue
        sensor = Sensor(setup.robot, setup.model, full_model=setup.controller.needs_dynamics)
        meas = sensor.measure(0.0, setup.q0.copy(), setup.v0.copy())
        setup.controller.step(meas)  # loads the kernels, makes the bundles
        period_args = setup.controller.law.period_arguments(meas, setup.scenario.dt)
        for row in ROWS:  # warm-up: compile or load the timing loops
            sample(row, period_args, 2)
        times: dict[str, list[float]] = {row: [] for row in ROWS}
        for _ in range(args.repeat):
            for row in ROWS:
                times[row].append(sample(row, period_args, args.number))
        whole = statistics.median(times["period, compiled loop"])
        print(f"{case} ({setup.model.n_joints} joints):")
        for row in ROWS:
            med = statistics.median(times[row])
            q = statistics.quantiles(times[row], n=4) if args.repeat > 1 else [med] * 3
            print(f"  {row:24s} {med * 1e6:8.2f}  {med / whole:6.1%}  "
                  f"({q[0] * 1e6:.2f} .. {q[2] * 1e6:.2f})", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
