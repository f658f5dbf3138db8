"""How far a built-in case's closed loop carries a rounding-sized change.

``tools/compare_runs.py`` says whether a code change kept a trajectory (bitwise, or to a
tolerance). This tool says what tolerance a trajectory *can* be held to: it runs a case as
shipped, then again with one initial joint angle moved by one unit in the last place (about
2e-16 rad, the size of one rounding), and prints, for each such run, how far the recorded
signals part (each signal's largest difference over its largest magnitude) and how the run
ended. Where one ulp grows to 1e-5 over the run, no change of the order of operations (a
compiled kernel, another BLAS) can stay within 1e-12 of the old trajectory; the honest
comparison is then against this envelope.

``--backend numba`` adds, for the paper's controller, a run on the compiled period (the planar
known-model scheme runs its numpy reference unless asked), so the two can be set side by side.

Usage::

    python tools/rounding_sensitivity.py known-model --backend numba
    python tools/rounding_sensitivity.py 1-paper --joints 0 1 2 3   # (case1-paper)
    python tools/rounding_sensitivity.py spatial --duration 10

Measured numbers and what they mean: benchmarks/README.md ("Rounding sensitivity").
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings

import numpy as np

from ffsm_pin import prepare
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim import loop

SIGNALS = ("q", "w", "u_m", "z_e")


def _run(scenario, joint: int | None = None, backend: str | None = None):
    setup = prepare(scenario)
    if backend is not None:
        compiled = LuJiaController(setup.controller.context, backend=backend)
        setup = dataclasses.replace(setup, controller=compiled)
    if joint is not None:  # one joint angle of the plant's initial state, one ulp up
        q0 = setup.q0.copy()
        i = setup.robot.root.nq + joint
        q0[i] = np.nextafter(q0[i], np.inf)
        setup = dataclasses.replace(setup, q0=q0)
    return loop.simulate(setup)


def _parting(ref, run) -> str:
    """Each signal's largest difference over its largest magnitude (common rows)."""
    out = []
    for key in SIGNALS:
        a, b = np.asarray(ref.signals[key]), np.asarray(run.signals[key])
        n = min(len(a), len(b))
        scale = float(np.abs(a[:n]).max()) or 1.0
        out.append(f"{key} {float(np.abs(a[:n] - b[:n]).max()) / scale:.2g}")
    return "  ".join(out)


def _ending(run) -> str:
    if run.completed:
        return "completed"
    return f"stopped at {run.stop_time:.4f} s ({run.stop_cause})"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case", help="a built-in scenario, or a case number (1, 1-paper)")
    p.add_argument("--joints", type=int, nargs="*", default=[0, 1], help="joints to move")
    p.add_argument("--duration", type=float, help="[s]; the case's own when omitted")
    p.add_argument("--backend", choices=("numba", "numpy"), help="also run the paper's law on it")
    args = p.parse_args(argv)
    scenario = builtin_scenario(f"case{args.case}" if args.case[:1].isdigit() else args.case)
    if args.duration is not None:
        scenario = dataclasses.replace(scenario, duration=args.duration)
    warnings.simplefilter("ignore")  # the runs' singularity notices
    ref = _run(scenario)
    print(f"{args.case}, {scenario.duration:g} s, as shipped: {_ending(ref)}")
    for joint in args.joints:
        run = _run(scenario, joint=joint)
        print(f"  joint {joint} + 1 ulp   {_parting(ref, run)}   {_ending(run)}")
    if args.backend is not None:
        run = _run(scenario, backend=args.backend)
        print(f"  backend {args.backend:6s}  {_parting(ref, run)}   {_ending(run)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
