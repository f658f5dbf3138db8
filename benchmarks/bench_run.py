"""What a whole simulation run costs per step, against a bare plant loop on the same robot.

Every row is a built-in case run as ``python -m ffsm_pin.sim --case NAME --duration D
--no-plots --no-html --quiet`` in a fresh process; its time is the loop's own (``wall_time_s``
of ``summary.json``, divided by its ``steps``), so start-up and file writing are not in it.

The baseline of each row, the bare plant loop, runs in another fresh process (this script with
``--bare``): ``prepare(scenario)`` builds the same robot and initial state as the run, then the
plant is made and called as ``simulate`` does (``Plant(robot, integrator=...)``, ``reset``, the
untimed ``project`` that loads the compiled projection, then ``plant.advance(q, v, u, dt,
substeps)`` once per step) with a constant zero torque, for the same number of steps. It is
Pinocchio's ABA, ``pin.integrate`` and the momentum projection, with nothing of the controller,
sensor or recorder. Its per-step time is that of steps 2..N (:func:`time.perf_counter` around
them): the first call of the step loads its compiled kernel from numba's cache (about 2 ms, a
few percent of a bare loop's time but 0.2 % of a run's, which pays it inside its loop too), so
it is timed apart and printed, not spread over the baseline's steps.

The same process then times the performance issue's own baseline, column ``py``: a bare Python
loop of ``pin.aba``, ``pin.integrate`` and the momentum projection in numpy (the base twist
solved by ``np.linalg.solve`` from the kept rows of ``pin.computeCentroidalMap``), as the issue
measured it, for the same steps from the same state. It costs about three times the package's
plant step (whose projection is compiled); the issue's targets are stated against it, and the
script prints each planar and spatial target against both.

Rows (``--cases``):

* ``planar``: the paper's case 1 (``--case 1``), every step recorded (the default);
* ``planar-every100``: the same with ``--record-every 100``;
* ``spatial``: the Panda on a satellite (``--case spatial``);
* ``spatial-pose``: the 9-joint arm with full pose tracking (``--case spatial-pose``);
* ``known-model``, ``spatial-known-model``: the true-parameter baselines of case 1 and spatial;
* ``known-model-numpy``: the planar one with ``[controller.params] backend = "numpy"`` (its
  numpy reference; the default runs the compiled period since 0.2.0, docs/controllers.md),
  as a scenario file written next to the run.

Samples are taken round-robin: each round runs, for every row in turn, the run and then its
bare loop, so a change of machine load hits both sides of a row alike and every row alike. The
first round is a discarded warm-up (numba compiles or loads its cache on first use); then
``--repeat`` timed rounds. Printed per row: the median per-step time of the run and of the bare
loop [us], their ratio, and the quartiles of the per-pair ratios (run / bare of the same round);
then the targets of the performance issue, each with the ratio of the medians and the quartiles
of the per-round ratios.

Usage::

    python benchmarks/bench_run.py                          # every row, 5 rounds (~2 min)
    python benchmarks/bench_run.py --cases planar spatial --repeat 3
    python benchmarks/bench_run.py --repeat 1 --duration-scale 0.2   # a quick check
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import checkout

ROOT = Path(__file__).resolve().parents[1]
PLANAR_S, SPATIAL_S = 10.0, 4.0  # default simulated durations [s]
# row -> (built-in scenario, spatial?, extra arguments of the run)
ROWS = {
    "planar": ("case1", False, []),
    "planar-every100": ("case1", False, ["--record-every", "100"]),
    "spatial": ("spatial", True, []),
    "spatial-pose": ("spatial-pose", True, []),
    "known-model": ("known-model", False, []),
    "known-model-numpy": ("known-model", False, []),
    "spatial-known-model": ("spatial-known-model", True, []),
}
# rows whose run sets [controller.params] (written as a scenario file next to the run)
PARAMS = {"known-model-numpy": {"backend": "numpy"}}
# rows of the centroidal momentum h_g = (P, L) the projection keeps, per root joint
MOMENTUM_ROWS = {"JointModelPlanar": [0, 1, 5], "JointModelFreeFlyer": [0, 1, 2, 3, 4, 5]}
# (label, numerator row, denominator: "py" the row's bare Python loop (the performance
# issue's baseline), "plant" the row's loop of the package's plant, or another row; at most)
TARGETS = [
    ("planar run / bare Python loop", "planar", "py", 2.5),
    ("spatial run / bare Python loop", "spatial", "py", 6.0),
    ("planar run / the package's plant loop", "planar", "plant", 2.5),
    ("spatial run / the package's plant loop", "spatial", "plant", 6.0),
    ("spatial-pose run / spatial run", "spatial-pose", "spatial", 1.5),
    ("spatial-known-model run / spatial run", "spatial-known-model", "spatial", 1.5),
    ("known-model run / planar run", "known-model", "planar", 1.5),
    ("known-model (backend numpy) / planar run", "known-model-numpy", "planar", 1.5),
    ("every step / --record-every 100", "planar", "planar-every100", 1.15),
]


def env() -> dict[str, str]:
    """The environment of the subprocesses: this checkout's package first."""
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def scenario_file(scenario: str, params: dict, folder: Path) -> Path:
    """The built-in ``scenario`` with ``[controller.params]`` set to ``params``, as a file."""
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.scenario.writer import scenario_to_toml

    sc = builtin_scenario(scenario)
    sc = dataclasses.replace(sc, controller=dataclasses.replace(sc.controller, params=params))
    path = folder / f"{scenario}-{'-'.join(map(str, params.values()))}.toml"
    path.write_text(scenario_to_toml(sc))
    return path


def run_step_time(
    scenario: str, duration: float, extra: list[str], out: Path, params: dict | None = None
) -> tuple:
    """(seconds per step, steps, completed) of one ``python -m ffsm_pin.sim`` run's loop;
    with ``params``, the built-in scenario's ``[controller.params]`` replaced."""
    source = ["--case", scenario]
    if params:
        source = ["--scenario", str(scenario_file(scenario, params, out.parent))]
    cmd = [sys.executable, "-m", "ffsm_pin.sim", *source, "--duration", str(duration)]
    cmd += [*extra, "--no-plots", "--no-html", "--quiet", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env(), check=False)
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr}")
    s = json.loads((out / "summary.json").read_text())
    return s["wall_time_s"] / s["steps"], s["steps"], s["completed"]


def bare_step_time(scenario: str, duration: float) -> dict:
    """The bare plant loop of ``scenario`` in a fresh process (this script with ``--bare``)."""
    cmd = [sys.executable, __file__, "--bare", scenario, "--duration", str(duration)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env(), check=False)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def bare_loop(scenario: str, duration: float) -> dict:
    """Time the plant alone as ``simulate`` drives it, zero torque, ``duration / dt`` steps."""
    import dataclasses
    import warnings

    import numpy as np

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.plant import Plant
    from ffsm_pin.sim.run import prepare

    sc = dataclasses.replace(builtin_scenario(scenario), duration=duration)
    with warnings.catch_warnings():  # reach and gain warnings: the run prints them, not this
        warnings.simplefilter("ignore")
        setup = prepare(sc)
    sc = setup.scenario
    dt, substeps = sc.dt, sc.substeps
    n_steps = int(round(sc.duration / dt))
    plant = Plant(setup.robot, integrator=sc.integrator)
    q, v = setup.q0.copy(), setup.v0.copy()
    u = np.zeros(setup.robot.n_joints)
    plant.reset(q, v)
    plant.project(q, v)  # as simulate does before its clock starts
    advance = plant.advance
    t0 = time.perf_counter()
    q, v, _ = advance(q, v, u, dt, substeps)  # loads the compiled step from numba's cache
    t1 = time.perf_counter()
    for _ in range(n_steps - 1):
        q, v, _ = advance(q, v, u, dt, substeps)
    wall = time.perf_counter() - t1
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise SystemExit(f"bare loop of {scenario}: the state became non-finite")
    q, v = setup.q0.copy(), setup.v0.copy()
    t2 = time.perf_counter()
    q, v = python_loop(plant, q, v, u, dt, substeps, n_steps - 1)
    wall_py = time.perf_counter() - t2
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise SystemExit(f"bare Python loop of {scenario}: the state became non-finite")
    return {"steps": n_steps - 1, "wall_time_s": wall, "first_step_s": t1 - t0,
            "python_wall_time_s": wall_py}  # fmt: skip


def python_loop(plant, q, v, u, dt: float, substeps: int, n_steps: int) -> tuple:
    """The performance issue's baseline: a bare Python loop of Pinocchio's ABA,
    ``pin.integrate`` and the momentum projection in numpy (the base twist solved from the
    kept rows of ``pin.computeCentroidalMap``), semi-implicit Euler as the plant's default,
    ``n_steps`` control steps of ``substeps`` plant steps, torque ``u`` held."""
    import numpy as np
    import pinocchio as pin

    model = plant.model
    data = model.createData()
    rows, nb = MOMENTUM_ROWS[plant.root], plant.n_base
    h0 = plant.momentum0
    tau = np.zeros(model.nv)
    tau[nb:] = u
    h = dt / substeps
    for _ in range(n_steps * substeps):
        a = pin.aba(model, data, q, v, tau)
        v = v + h * a
        q = pin.integrate(model, q, h * v)
        Ag = pin.computeCentroidalMap(model, data, q)[rows]
        v[:nb] = np.linalg.solve(Ag[:, :nb], h0 - Ag[:, nb:] @ v[nb:])
    return q, v


def quartiles(x: list[float]) -> list[float]:
    """First quartile, median, third quartile (all three x[0] for one sample)."""
    return statistics.quantiles(x, n=4) if len(x) > 1 else [x[0]] * 3


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", choices=list(ROWS), default=list(ROWS))
    parser.add_argument("--repeat", type=int, default=5, help="timed rounds (default 5)")
    parser.add_argument("--planar-duration", type=float, default=PLANAR_S, metavar="S")
    parser.add_argument("--spatial-duration", type=float, default=SPATIAL_S, metavar="S")
    parser.add_argument("--duration-scale", type=float, default=1.0, metavar="F",
                        help="multiply both durations (default 1)")  # fmt: skip
    parser.add_argument("--bare", metavar="SCENARIO", help=argparse.SUPPRESS)
    parser.add_argument("--duration", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.bare:  # the subprocess of one bare plant loop: one JSON line on stdout
        print(json.dumps(bare_loop(args.bare, args.duration)))
        return 0

    import numba
    import numpy
    import pinocchio

    load = os.getloadavg()
    print(f"ffsm-pin run benchmark: {checkout(ROOT)}, "
          f"python {sys.version.split()[0]}, pinocchio {pinocchio.__version__}, numpy "
          f"{numpy.__version__}, numba {numba.__version__}, {os.cpu_count()} CPU(s), "
          f"load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")  # fmt: skip
    rows = {}
    for name in args.cases:
        scenario, spatial, extra = ROWS[name]
        duration = (
            args.spatial_duration if spatial else args.planar_duration
        ) * args.duration_scale
        rows[name] = (scenario, duration, extra)
    print(
        f"us per step: median of {args.repeat} rounds after 1 warm-up, rows round-robin, each "
        "run followed by its bare plant loop; ratio = run / bare (pairs: per-round q1 .. q3)"
    )
    print("-" * 100)
    run_t: dict[str, list[float]] = {name: [] for name in rows}
    bare_t: dict[str, list[float]] = {name: [] for name in rows}
    py_t: dict[str, list[float]] = {name: [] for name in rows}
    first: list[float] = []
    steps: dict[str, int] = {}
    stopped: set[str] = set()
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="ffsm-bench-run-") as tmp_name:
        tmp = Path(tmp_name)
        for k in range(args.repeat + 1):
            for name, (scenario, duration, extra) in rows.items():
                tr, n, completed = run_step_time(
                    scenario, duration, extra, tmp / name, PARAMS.get(name)
                )
                bare = bare_step_time(scenario, duration)
                if not completed:
                    stopped.add(name)
                if k:  # round 0 warms numba's caches and the file system
                    run_t[name].append(tr)
                    bare_t[name].append(bare["wall_time_s"] / bare["steps"])
                    py_t[name].append(bare["python_wall_time_s"] / bare["steps"])
                    first.append(bare["first_step_s"])
                    steps[name] = n
            print(f"  round {k}/{args.repeat} done ({time.perf_counter() - t_start:.0f} s)",
                  file=sys.stderr, flush=True)  # fmt: skip
    print(f"{'row':22s} {'D [s]':>6s} {'steps':>6s} {'run':>9s} {'bare':>9s} {'run-bare':>9s} "
          f"{'ratio':>7s}  pairs          {'py':>7s} {'run/py':>7s}")  # fmt: skip
    for name, (_, duration, _) in rows.items():
        mr, mb = statistics.median(run_t[name]), statistics.median(bare_t[name])
        mp = statistics.median(py_t[name])
        q = quartiles([r / b for r, b in zip(run_t[name], bare_t[name], strict=True)])
        note = "  (stopped early)" if name in stopped else ""
        us = f"{mr * 1e6:9.2f} {mb * 1e6:9.2f} {(mr - mb) * 1e6:9.2f}"
        print(f"{name:22s} {duration:6g} {steps[name]:6d} {us} {mr / mb:6.2f}x  "
              f"{q[0]:5.2f} .. {q[2]:5.2f}  {mp * 1e6:7.2f} {mr / mp:6.2f}x{note}")  # fmt: skip
    print("-" * 100)
    print("targets (performance issue): ratio of medians (per-round q1 .. q3)")
    for label, num, den, limit in TARGETS:
        if num not in rows or den not in (*rows, "py", "plant"):
            continue
        base = {"py": py_t[num], "plant": bare_t[num]}.get(den) or run_t[den]
        ratios = [a / b for a, b in zip(run_t[num], base, strict=True)]
        value = statistics.median(run_t[num]) / statistics.median(base)
        q = quartiles(ratios)
        verdict = "met" if value <= limit else "NOT met"
        print(f"{label:40s} {value:6.2f}x ({q[0]:.2f} .. {q[2]:.2f})  target <= {limit:g}x: "
              f"{verdict}")  # fmt: skip
    print("-" * 100)
    print(
        f"note: the first step of a bare loop (numba loads the semi-implicit kernel from its "
        f"cache) took {statistics.median(first) * 1e3:.2f} ms (median); the bare column is "
        "steps 2..N, the run's loop time includes its own first step; py = the performance "
        "issue's bare Python loop (pin.aba, pin.integrate, numpy projection), same steps"
    )
    print(f"total {time.perf_counter() - t_start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
