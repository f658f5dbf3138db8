"""Where the paper's compiled control period spends its time: its three steps one by one.

:func:`ffsm_pin.control.period.period` runs three compiled steps per geometry (docs/
controllers.md): the geometry's terms and the estimates' laws (Eqs. 28, 42), the kinematic law
at complex arguments (Eqs. 25+36, its exact derivative by the complex step) and the dynamic
level (Eqs. 46, 49-52, 60-64). For each case this benchmark runs the case for ``--duration``
seconds (``simulate``) and keeps the sensor's exact measurement of every recorded state; a
controller prepared afresh replays them once, period after period, keeping the state each
period starts from (every replayed period must end with ``STATUS_OK``: a period that stops
early, at a funnel exit or a singular estimate, costs a fraction of one that does not, and
would make the rows meaningless). Each sample then times, over the whole sequence in a
compiled loop (numba's dispatch paid once per loop, not per period):

* ``geometry``: the geometry step at each (measurement, state);
* ``kinematic``: the geometry step and the kinematic law with the period's complex arguments
  built around it, less the row above;
* ``kinematic, real arguments``: the geometry step and the kinematic law at the same values as
  real arguments (no derivative), less the geometry row: what the law costs without the
  complex step, beside the ``kinematic`` row;
* ``dynamic``: those and the dynamic level (on copies of the states: it advances them), less
  the row above;
* ``period, compiled loop``: the whole period along the sequence from its first state (the
  replay itself);
* ``period, from Python``: the same called from Python once per period, as the controller
  does (:func:`~ffsm_pin.control.period.period_of` with a box of the fixed arguments; the
  difference to the row above is numba's dispatch: typing and unboxing the box, the
  measurement and ``dt``, and boxing the result);
* ``period, bundles unboxed``: the same with the fixed arguments as separate bundles, as the
  controller called the period before the box (numba unboxes each of their arrays per call;
  the box is then made in compiled code): the box's saving, side by side.

Samples are taken round-robin over the rows (``--repeat`` rounds), so a change of machine load
hits every row alike; printed per case: each row's median us per period, its share of the
compiled period, and the quartiles over rounds. The steps' sum is less than the period: the
period also writes its outputs and builds the complex arguments once more. (Until 2026-11-28
this benchmark repeated the initial measurement ``--number`` times: the spatial estimates then
left their valid set after 35-55 periods and the rest stopped early, so its spatial rows
timed mostly early stops; benchmarks/README.md, "The period's parts".)

Usage::

    python benchmarks/bench_period_parts.py                  # case1 and spatial-realistic
    python benchmarks/bench_period_parts.py --cases spatial --duration 1 --repeat 9
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path
from typing import Any, NamedTuple

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from _timing import checkout  # noqa: E402
from bench_period_call import measurements  # noqa: E402
from numba import njit  # noqa: E402
from numba.typed import List  # noqa: E402

import ffsm_pin  # noqa: E402  (first: the package's numba settings)
from ffsm_pin.control.compiled_period import CompiledPeriod  # noqa: E402
from ffsm_pin.control.interface import Measurement  # noqa: E402
from ffsm_pin.control.kernels import COMPLEX_STEP, STATUS_OK  # noqa: E402
from ffsm_pin.control.period import (  # noqa: E402
    KernelGains,
    PeriodBox,
    PeriodLaw,
    PeriodState,
    dynamic_level,
    geometry_terms,
    kinematic_law,
    period_box,
    period_of,
)
from ffsm_pin.control.reference_kernels import ReferenceArrays  # noqa: E402
from ffsm_pin.scenario.file import builtin_scenario  # noqa: E402
from ffsm_pin.sim.setup import prepare  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
STEPS = ("geometry", "kinematic", "dynamic")  # rows timed by time_steps, cumulatively
REAL_LAW = "kinematic, real arguments"  # timed by time_real_law, less the geometry row
ROWS = (
    "geometry", "kinematic", REAL_LAW, "dynamic", "period, compiled loop",
    "period, from Python", "period, bundles unboxed",
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
def time_steps(geo, law_f, ref_f, dt, metas, states, last):
    """The period's first ``last`` steps (1: geometry, 2: and the kinematic law, 3: and the
    dynamic level) at each (measurement, state) of the sequence."""
    acc = 0.0
    for k in range(len(metas)):
        law, ref, meas, state = _bundles(law_f, ref_f, metas[k], states[k])
        terms, tb_new, tz_new, q_b_rate, w_b = geometry_terms(geo, law, dt, meas, state)
        acc += tb_new[0]
        if last == 1:
            continue
        w_mc_c, sens, sigma = _complex_law(geo, law, ref, dt, meas, state, tb_new, tz_new,
                                           q_b_rate, w_b)[:3]  # fmt: skip
        acc += sigma
        if last == 2:
            continue
        w_mc = w_mc_c.real.copy()
        w_mc_dot = w_mc_c.imag / COMPLEX_STEP
        sens = np.ascontiguousarray(sens)
        acc += dynamic_level(geo, terms, law, dt, meas, w_mc, w_mc_dot, sens, state)[1]
    return acc


@njit(cache=True)
def time_real_law(geo, law_f, ref_f, dt, metas, states):
    """The geometry step and the kinematic law at real arguments (the values the period's
    complex arguments have, without their steps) at each (measurement, state)."""
    acc = 0.0
    for k in range(len(metas)):
        law, ref, meas, state = _bundles(law_f, ref_f, metas[k], states[k])
        w_b = geometry_terms(geo, law, dt, meas, state)[4]
        acc += kinematic_law(geo, law, ref, law.null_space, meas.t, meas.q_b, meas.q_m,
                             meas.z_e, state.theta_b, state.theta_z, w_b)[2]  # fmt: skip
    return acc


@njit(cache=True)
def time_period(box, dt, metas):
    acc = 0.0
    for k in range(len(metas)):
        acc += period_of(box, dt, metas[k], None)[2]
    return acc


@njit(cache=True)
def period_unboxed(geo, law_f, ref_f, dt, meas_f, state_f, out_f, aux):
    """The period called with its bundles as separate arguments (as before the box): numba
    unboxes every array of them per call; the box is made in compiled code."""
    return period_of(PeriodBox(geo, law_f, ref_f, state_f, out_f), dt, meas_f, aux)


class Replay(NamedTuple):
    """A case's sequence: the period's fixed arguments, the measurements' fields from the
    second recorded state on, and the state each of those periods starts from (copies)."""

    geo: Any
    law: tuple
    ref: tuple
    dt: float
    out: tuple
    metas: list
    states: list


def replay_of(case: str, duration: float) -> Replay:
    """Run ``case`` for ``duration`` [s], then replay its exact measurements once through a
    controller prepared afresh (its first period loads the kernels), keeping each period's
    starting state; every period must end with ``STATUS_OK``."""
    scenario = dataclasses.replace(builtin_scenario(case), duration=duration)
    metas = measurements(scenario)
    law = prepare(scenario).controller.law
    dt = scenario.dt
    law.step(metas[0], dt)  # loads the kernels, makes the bundles
    first = law.period_arguments(metas[0], dt)
    geo, law_f, ref_f, out = first.geo, first.law, first.ref, first.out
    fields, states = [], []
    box = None
    for meas in metas[1:]:
        args = law.period_arguments(meas, dt)
        states.append(tuple(x.copy() for x in args.state))
        fields.append(args.meas)
        box = box or period_box(geo, law_f, ref_f, args.state, out)
        status = period_of(box, dt, args.meas, args.aux)[0]
        if status != STATUS_OK:
            raise SystemExit(
                f"{case}: the replayed period at t = {meas.t:.4f} s ended with status "
                f"{status}, not STATUS_OK: the rows would time a stop"
            )
    return Replay(geo, law_f, ref_f, dt, out, fields, states)


def sample(row: str, rep: Replay) -> float:
    """Seconds per period of ``row`` over the sequence, from fresh copies of its states."""
    geo, law, ref, dt, out, metas, states = rep
    if row in STEPS or row == REAL_LAW:
        compiled = List(metas)  # (a typed list for the compiled loops; Python iterates metas)
        copies = List([tuple(x.copy() for x in st) for st in states])
        t0 = time.perf_counter()
        if row == REAL_LAW:
            time_real_law(geo, law, ref, dt, compiled, copies)
        else:
            time_steps(geo, law, ref, dt, compiled, copies, STEPS.index(row) + 1)
        return (time.perf_counter() - t0) / len(metas)
    state = tuple(x.copy() for x in states[0])
    box = period_box(geo, law, ref, state, out)
    if row == "period, compiled loop":
        compiled = List(metas)
        t0 = time.perf_counter()
        time_period(box, dt, compiled)
        return (time.perf_counter() - t0) / len(metas)
    t0 = time.perf_counter()
    if row == "period, from Python":
        for meas in metas:
            period_of(box, dt, meas, None)
    else:
        for meas in metas:
            period_unboxed(geo, law, ref, dt, meas, state, out, None)
    return (time.perf_counter() - t0) / len(metas)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=["case1", "spatial-realistic"])
    parser.add_argument("--duration", type=float, default=1.0, help="replayed seconds")
    parser.add_argument("--repeat", type=int, default=7, help="timed rounds (default 7)")
    args = parser.parse_args()
    package = Path(ffsm_pin.__file__).resolve().parent
    here = f"{checkout(ROOT)}, " if package.parent == ROOT else ""
    print(f"ffsm-pin period-parts benchmark: {here}ffsm_pin from {package}, "
          f"python {sys.version.split()[0]}")  # fmt: skip
    print("us per period: median over rounds (q1 .. q3); share = of the compiled loop's period")
    for case in args.cases:
        law = prepare(builtin_scenario(case)).controller.law
        if not isinstance(law, CompiledPeriod) or law.auxiliary is not None or not law.adaptive:
            print(f"{case}: not the paper's adaptive law with its own period; skipped")
            continue
        rep = replay_of(case, args.duration)
        for row in ROWS:  # warm-up: compile or load the timing loops
            sample(row, rep._replace(metas=rep.metas[:2], states=rep.states[:2]))
        times: dict[str, list[float]] = {row: [] for row in ROWS}
        for _ in range(args.repeat):
            for row in ROWS:
                times[row].append(sample(row, rep))
        # the kinematic and dynamic rows time the steps before them too: their differences
        for later, earlier in ((STEPS[2], STEPS[1]), (STEPS[1], STEPS[0]), (REAL_LAW, STEPS[0])):
            times[later] = [a - b for a, b in zip(times[later], times[earlier], strict=True)]
        whole = statistics.median(times["period, compiled loop"])
        print(f"{case} ({len(rep.metas)} periods, {law.model.n_joints} joints):")
        for row in ROWS:
            med = statistics.median(times[row])
            q = statistics.quantiles(times[row], n=4) if args.repeat > 1 else [med] * 3
            print(f"  {row:25s} {med * 1e6:8.2f}  {med / whole:6.1%}  "
                  f"({q[0] * 1e6:.2f} .. {q[2] * 1e6:.2f})", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
