"""What the controller interface, the actuators and the sensors cost a whole run (issue 17).

Every run is one ``python -m ffsm_pin.sim`` in a fresh process (``--no-plots --no-html
--quiet``, recording every step); the time compared is the loop's own (``wall_time_s`` of
``summary.json``), so start-up and file writing do not dilute the ratios. Since bc54e04
``wall_time_s`` also covers the signals computed after the loop (funnels, reference, errors,
F_r: a few ms); an ``interface`` comparison with an older revision counts them on one side
only. Runs are interleaved (A, B, A, B, ...) so that a change of machine load hits both sides
alike, and the first run of each side is a discarded warm-up (numba's cache is per source
folder).

* ``interface``: the package as it is against a baseline revision checked out beside it
  (default: the last commit before the controller interface, where the run loop called the
  paper's controller directly), same built-in case, same duration.
* ``baselines``: the paper's controller against each built-in baseline (``gjm-ct``,
  ``adaptive-ct``), same case and duration, every side the package as it is.
* ``world``: the package with ideal actuators and sensors against the same case with torque
  limits, rate limit, lag and torque noise (``[actuators]``) and sensor noise on every
  quantity with a delay of 2 periods (``[sensors]``).

Usage::

    python benchmarks/bench_controller.py                    # both, planar case 1 and spatial
    python benchmarks/bench_controller.py --parts world --repeat 7
    python benchmarks/bench_controller.py --baseline <rev>   # any git revision
    python benchmarks/bench_controller.py --parts baselines --duration-scale 5

Printed per case: the median loop time per step [us] of each side over ``--repeat`` runs
(with the steps each side ran: a run that stops early has fewer), their ratio (B / A), and the
quartiles of the per-pair ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASELINE = "36c8c4d"  # main before the controller interface (issue 17)
CASES = {"planar": ("case1", 10.0), "spatial": ("spatial", 4.0)}
WORLD = """
[actuators]
torque_limit = 50.0
rate_limit = 2000.0
time_constant = 0.005
torque_noise = 0.01
seed = 1

[sensors]
seed = 2
delay = 2

[sensors.noise]
joints = 1e-4
joint_rates = 1e-4
base_attitude = 1e-4
base_rate = 1e-4
ee_pose = 1e-4
ee_velocity = 1e-4
"""


def loop_time(args: list[str], out: Path, source: Path) -> tuple[float, int]:
    """The loop's wall time per step [s] of one run of ``python -m ffsm_pin.sim args`` from
    ``source``, and its number of steps (a run that stops early has fewer)."""
    env = {**os.environ, "PYTHONPATH": str(source)}
    cmd = [sys.executable, "-m", "ffsm_pin.sim", *args]
    cmd += ["--no-plots", "--no-html", "--quiet", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr}")
    summary = json.loads((out / "summary.json").read_text())
    steps = max(int(summary["steps"]), 1)
    return float(summary["wall_time_s"]) / steps, steps


def compare(name: str, sides: dict, repeat: int, tmp: Path) -> None:
    """Interleaved runs of two sides {label: (args, source)}; print the median time per step
    of each side [us], their ratio and each side's steps (fewer when its run stopped)."""
    (la, (args_a, src_a)), (lb, (args_b, src_b)) = sides.items()
    times: dict[str, list[float]] = {la: [], lb: []}
    steps: dict[str, int] = {}
    for k in range(repeat + 1):
        (ta, steps[la]) = loop_time(args_a, tmp / f"{name}-a", src_a)
        (tb, steps[lb]) = loop_time(args_b, tmp / f"{name}-b", src_b)
        if k:  # the first pair warms numba's caches and the file system
            times[la].append(ta)
            times[lb].append(tb)
    ma, mb = statistics.median(times[la]), statistics.median(times[lb])
    ratios = sorted(b / a for a, b in zip(times[la], times[lb], strict=True))
    q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratios[0]] * 3
    print(f"{name:22s} {la:>10s} {ma * 1e6:7.1f} us ({steps[la]} steps)  {lb:>10s} "
          f"{mb * 1e6:7.1f} us ({steps[lb]} steps)  ratio {mb / ma:6.3f} "
          f"(pairs: {q[0]:.3f} .. {q[2]:.3f})", flush=True)  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", nargs="+", choices=["interface", "world", "baselines"],
                        default=["interface", "world", "baselines"])  # fmt: skip
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=sorted(CASES))
    parser.add_argument("--repeat", type=int, default=5, help="timed runs per side")
    parser.add_argument("--baseline", default=BASELINE, help="git revision for 'interface'")
    parser.add_argument("--duration-scale", type=float, default=1.0,
                        help="multiply every case's duration (longer runs dilute the first "
                             "step, where numba loads the kernels from its cache)")  # fmt: skip
    args = parser.parse_args()
    load = os.getloadavg()
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()  # fmt: skip
    print(f"ffsm-pin controller benchmark: HEAD {head}, python {sys.version.split()[0]}, "
          f"{os.cpu_count()} CPU(s), load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="ffsm-bench-ctrl-") as tmp_name:
        tmp = Path(tmp_name)
        if "interface" in args.parts:
            base = tmp / "baseline"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q",
                            str(base), args.baseline], check=True)  # fmt: skip
            try:
                for case in args.cases:
                    name, duration = CASES[case]
                    duration *= args.duration_scale
                    run = ["--case", name, "--duration", str(duration)]
                    compare(f"interface {case}", {f"{args.baseline}": (run, base),
                            "HEAD": (run, ROOT)}, args.repeat, tmp)  # fmt: skip
            finally:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                str(base)], check=False)  # fmt: skip
        if "world" in args.parts:
            from ffsm_pin.scenario.file import builtin_path

            for case in args.cases:
                name, duration = CASES[case]
                duration *= args.duration_scale
                text = Path(builtin_path(name)).read_text()
                path = tmp / f"{case}-world.toml"
                path.write_text(text + WORLD)
                ideal = ["--case", name, "--duration", str(duration)]
                world = ["--scenario", str(path), "--duration", str(duration)]
                compare(f"world {case}", {"ideal": (ideal, ROOT), "limits+noise": (world, ROOT)},
                        args.repeat, tmp)  # fmt: skip
        if "baselines" in args.parts:
            from ffsm_pin.scenario.file import builtin_path

            for case in args.cases:
                name, duration = CASES[case]
                duration *= args.duration_scale
                paper = ["--case", name, "--duration", str(duration)]
                text = Path(builtin_path(name)).read_text()
                for kind in ("gjm-ct", "adaptive-ct"):
                    path = tmp / f"{case}-{kind}.toml"
                    kind_line = f'[controller]\ntype = "{kind}"\n'
                    path.write_text(text.replace("[controller]\n", kind_line))
                    other = ["--scenario", str(path), "--duration", str(duration)]
                    compare(f"{kind} {case}", {"lu-jia": (paper, ROOT), kind: (other, ROOT)},
                            args.repeat, tmp)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
