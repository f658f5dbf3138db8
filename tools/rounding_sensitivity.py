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

``--blas CORETYPE ...`` adds the same run, unchanged, with OpenBLAS forced to other kernels of
this machine (``OPENBLAS_CORETYPE``, each in a new process; the wheels' OpenBLAS picks its
kernel at run time): what the shipped trajectory is on another CPU with the same code.

``--source DIR ...`` adds the same run made by the package of another source folder (a ``git
archive`` of an earlier revision, say), in a new process: how far a code change moved the
trajectory, to set beside the one-ulp rows (a change that reorders arithmetic is accepted
when every verdict is equal and it parts by at most ten times the envelope,
docs/REPRODUCTION.md).

Usage::

    python tools/rounding_sensitivity.py known-model --backend numba
    python tools/rounding_sensitivity.py 1-paper --joints 0 1 2 3   # (case1-paper)
    python tools/rounding_sensitivity.py spatial --duration 10
    python tools/rounding_sensitivity.py 1 --joints --blas Haswell Sandybridge
    git archive REV | tar -x -C /tmp/old && python tools/rounding_sensitivity.py 1 --source /tmp/old

Measured numbers and what they mean: benchmarks/README.md ("Rounding sensitivity").
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import ffsm_pin
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


def _saved(path: Path, run) -> None:
    """The signals :func:`_parting` and :func:`_ending` read, to a file (``--save``), with the
    package that made them."""
    np.savez(path, **{k: np.asarray(run.signals[k]) for k in SIGNALS},
             completed=run.completed, stop_time=np.nan if run.stop_time is None else run.stop_time,
             stop_cause=str(run.stop_cause),
             package=str(Path(ffsm_pin.__file__).resolve().parent))  # fmt: skip


def _loaded(path: Path):
    with np.load(path) as f:
        return SimpleNamespace(
            signals={k: f[k] for k in SIGNALS}, completed=bool(f["completed"]),
            stop_time=float(f["stop_time"]), stop_cause=str(f["stop_cause"]),
            package=str(f["package"]) if "package" in f else "?",
        )  # fmt: skip


def _in_new_process(args, env: dict[str, str]):
    """The run as shipped, in a new process with the environment ``env`` (from a temporary
    folder, so that no ``ffsm_pin`` of the current folder shadows the one asked for)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.npz"
        cmd = [sys.executable, str(Path(__file__).resolve()), args.case, "--joints"]
        cmd += ["--save", str(out)]
        if args.duration is not None:
            cmd += ["--duration", str(args.duration)]
        subprocess.run(cmd, env={**os.environ, **env}, cwd=tmp, check=True)
        return _loaded(out)


def _with_blas_kernel(args, coretype: str):
    """The run as shipped, in a new process with OpenBLAS forced to ``coretype``."""
    return _in_new_process(args, {"OPENBLAS_CORETYPE": coretype})


def _from_source(args, source: str):
    """The run made by the package of the folder ``source``, in a new process."""
    folder = Path(source).resolve()
    if not (folder / "ffsm_pin" / "__init__.py").is_file():
        raise SystemExit(f"error: --source {source}: no ffsm_pin package in that folder")
    path = os.pathsep.join(filter(None, [str(folder), os.environ.get("PYTHONPATH", "")]))
    run = _in_new_process(args, {"PYTHONPATH": path})
    if Path(run.package) != folder / "ffsm_pin":
        raise SystemExit(f"error: --source {source}: the run imported {run.package}")
    return run


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
    p.add_argument(
        "--blas",
        nargs="*",
        default=[],
        metavar="CORETYPE",
        help="also run it with OpenBLAS forced to these kernels (e.g. Haswell)",
    )
    p.add_argument(
        "--source",
        nargs="*",
        default=[],
        metavar="DIR",
        help="also run it with the package of these source folders (e.g. an earlier revision)",
    )
    p.add_argument("--save", help=argparse.SUPPRESS)  # (the --blas runs' own processes)
    args = p.parse_args(argv)
    scenario = builtin_scenario(f"case{args.case}" if args.case[:1].isdigit() else args.case)
    if args.duration is not None:
        scenario = dataclasses.replace(scenario, duration=args.duration)
    warnings.simplefilter("ignore")  # the runs' singularity notices
    ref = _run(scenario)
    if args.save:
        _saved(Path(args.save), ref)
        return 0
    print(f"{args.case}, {scenario.duration:g} s, as shipped: {_ending(ref)}")
    for joint in args.joints:
        run = _run(scenario, joint=joint)
        print(f"  joint {joint} + 1 ulp   {_parting(ref, run)}   {_ending(run)}")
    if args.backend is not None:
        run = _run(scenario, backend=args.backend)
        print(f"  backend {args.backend:6s}  {_parting(ref, run)}   {_ending(run)}")
    for coretype in args.blas:
        run = _with_blas_kernel(args, coretype)
        print(f"  OpenBLAS {coretype:11s} {_parting(ref, run)}   {_ending(run)}")
    for source in args.source:
        run = _from_source(args, source)
        print(f"  source {source}   {_parting(ref, run)}   {_ending(run)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
