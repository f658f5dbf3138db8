"""Campaign throughput on Dask against the serial loop of single runs (ffsm_pin.sweep).

Usage::

    python benchmarks/bench_sweep.py                  # 20 cases x 3 trials, then 100 cases
    python benchmarks/bench_sweep.py --cases 10 --trials 1 --big 0     # quick look
    python benchmarks/bench_sweep.py --big 1000       # the 1000-case campaign itself
    python benchmarks/bench_sweep.py --engine --trials 3   # batched / unbatched / bare loop
    python benchmarks/bench_sweep.py --engine --baseline main   # this checkout against main

The cases are those of a campaign on the paper's case 1 (10 s simulated, dt = 1 ms, estimates
perturbed by up to 20 %, one seed per case). In each trial, side by side:

* **serial**: the same cases one after the other in this process,
  ``simulate(prepare(scenario))`` (the kernels are warm; no Dask, no Parquet);
* **campaign, 2 workers**: ``python -m ffsm_pin.sweep CAMPAIGN --scheduler ... --force`` run
  in this process (``ffsm_pin.sweep.cli.main``) on a running LocalCluster of 2 single-threaded
  workers (already warm: cluster start-up is reported separately): expansion, validation,
  scheduling, transfer, atomic Parquet rewrites as rows arrive, report;
* **campaign, 1 worker**: the same on a 1-worker cluster. Its excess over the serial loop,
  per case, is the per-case overhead of the campaign machinery.
* **2 plain processes** (no Dask, no Parquet): the same cases spread over a
  ``multiprocessing`` pool of 2 warm processes (``spawn``), one case per task. This is what the
  machine itself gives two processes at that moment: on a virtual machine whose second vCPU is
  not a free core, serial / 2 processes stays below 2 whatever the engine does, and
  2 processes / campaign on 2 workers is the share of it the campaign delivers.

Trials are interleaved (serial, 2 workers, 1 worker, serial, ...) so a change of machine load
hits all three alike; the medians over trials are reported. Ratios: speed-up = serial / 2
workers (target >= 1.8 on 2 cores), overhead = (1 worker - serial) / serial (target <= 5 %).

CPU time is measured next to wall time: the serial loop's thread, and for a campaign this
process (client, scheduler, Parquet, report) plus every worker process (``getrusage`` on the
workers). On a machine shared with other jobs, wall-time ratios measure the cores the other
jobs leave free; the CPU-time overhead still measures what the campaign machinery costs.
``--big N`` then runs one N-case campaign on the 2-worker cluster and reports its wall time.

**Engine** (``--engine``, alone): per simulated step, a campaign on a 1-worker cluster (three
controllers x (1 + ``--engine-repeat``) cases, actuators and sensors on; planar case 1 and the
spatial ``spatial-realistic``), run in batches (:mod:`ffsm_pin.sweep.batches`, default size or
``--batch-size``) and one case per task (``--batch-size 1``), against the bare Python plant
loop of bench_run.py (``py``) on the same scenario; whole campaign wall time (through the
command line's entry point, cluster start-up excluded) over its total steps. Trials rotate the
order of the three; printed: medians, ratios to the bare loop per trial, and per case where
the time goes (outside cases, in a case outside its loop, the loop). Rows ``- fixed``: the
same without the campaign's fixed cost (expansion, set-up checks, report with its figures),
timed by running the campaign again into its folder (a resume with nothing to run).

**Engine against a baseline** (``--engine --baseline REV``): the same campaigns (run in batches,
default size) from this checkout and from ``REV`` (a git worktree in a temporary folder), each
trial in a child process per side (``FFSM_BENCH_TREE``: which tree it imports; its own warm
1-worker cluster, cluster start-up and warm-up untimed), sides in a rotated order, and the bare
Python plant loop in this process in the same trial; printed: per step and per case, medians
and the per-trial ratios this checkout / ``REV``.

**Paired per-case CPU** (``--paired N``, robust to machine load): the same case, one after the
other, (a) in this process's main thread, (b) on the worker of a 1-worker cluster started as
the campaign starts it (:func:`ffsm_pin.sweep.engine.start_client`) and (c) on the worker of a
1-worker LocalCluster with Dask's default settings, in a shuffled order per case. Reported: the
case's thread CPU in each (median of the per-case ratios to (a)), its minor page faults and
system time, and the worker process's CPU outside the case (profiler, event loop, monitors,
task transfer), as a share of the case's CPU.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import multiprocessing
import os
import random
import resource
import shutil
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import pyarrow.parquet as pq

HERE = Path(__file__).resolve().parent
#: the ffsm_pin measured: this checkout's, or (``--baseline``'s child processes) another tree's
TREE = Path(os.environ.get("FFSM_BENCH_TREE") or HERE.parent).resolve()
sys.path.insert(0, str(TREE))  # also for the workers (spawned with this sys.path)

CAMPAIGN = """\
[campaign]
name = "bench"
scenario = "case1"
seed = {seed}
repeat = {repeat}
duration = 10.0

[campaign.set]
"controller.estimates.initial" = "perturbed"
"controller.estimates.spread" = 0.2
"""


def write_campaign(folder: Path, n_cases: int, seed: int) -> Path:
    """A campaign of ``n_cases`` cases: the nominal case plus ``n_cases - 1`` seeds."""
    path = folder / f"bench-{n_cases}-{seed}.toml"
    path.write_text(CAMPAIGN.format(seed=seed, repeat=n_cases - 1))
    return path


def serial(path: Path) -> float:
    from ffsm_pin.scenario.file import scenario_from_toml
    from ffsm_pin.sim.run import prepare, simulate
    from ffsm_pin.sweep.campaign import load_campaign
    from ffsm_pin.sweep.cases import expand

    cases = expand(load_campaign(path))
    # thread_time: this thread only (the idle clusters' scheduler threads live in this process)
    t0, c0 = time.perf_counter(), time.thread_time()
    for case in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate(prepare(scenario_from_toml(case.scenario_toml)))
    return time.perf_counter() - t0, time.thread_time() - c0


def _pool_init() -> None:
    """Load the kernels in a pool process (numba's on-disk cache) before any timed case."""
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.run import prepare, simulate

    sc = builtin_scenario("case1")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(prepare(dataclasses.replace(sc, duration=20 * sc.dt)))


def _pool_case(scenario_toml: str) -> float:
    """One case in a pool process; its thread CPU [s] (:func:`_one_case`)."""
    return _one_case(scenario_toml)["cpu"]


def processes(path: Path, pool) -> tuple[float, float]:
    """Wall time and the cases' CPU time of the cases on a pool of plain processes."""
    from ffsm_pin.sweep.campaign import load_campaign
    from ffsm_pin.sweep.cases import expand

    tomls = [case.scenario_toml for case in expand(load_campaign(path))]
    t0 = time.perf_counter()
    cpu = pool.map(_pool_case, tomls, chunksize=1)
    return time.perf_counter() - t0, sum(cpu)


def _worker_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def campaign(
    path: Path, client, out: Path, force: bool = True, extra: tuple[str, ...] = ()
) -> tuple[float, float]:
    """Wall time and CPU time (this process, which also hosts the scheduler, plus every
    worker process) of one campaign run through the command line's entry point.

    ``force=False`` on a finished folder resumes with nothing to run: the campaign's fixed
    cost (expansion, validation, reading and writing results.parquet, the report)."""
    from ffsm_pin.sweep import cli

    address = client.scheduler.address
    w0 = sum(client.run(_worker_cpu).values())
    t0, c0 = time.perf_counter(), time.process_time()
    argv = [str(path), "--out", str(out), "--scheduler", address, "--quiet", *extra]
    with contextlib.redirect_stdout(io.StringIO()):  # --quiet prints the output folder
        status = cli.main(argv + (["--force"] if force else []))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if status != 0:
        raise SystemExit(f"campaign {path.name} exited with status {status}")
    return wall, cpu + sum(client.run(_worker_cpu).values()) - w0


def start_cluster(n: int, dask_defaults: bool = False):
    """A LocalCluster of ``n`` workers as the campaign starts it, or with Dask's defaults."""
    from distributed import Client, LocalCluster

    from ffsm_pin.sweep.engine import start_client

    t0 = time.perf_counter()
    if dask_defaults:
        os.environ.pop("MALLOC_TRIM_THRESHOLD_", None)  # leaked by an earlier nanny: not ours
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            lc = LocalCluster(
                n_workers=n, threads_per_worker=1, dashboard_address=None, silence_logs=50
            )
        client = Client(lc)
    else:
        client, lc = start_client(n, quiet=True)
    return lc, client, time.perf_counter() - t0


def _one_case(scenario_toml: str) -> dict[str, float]:
    """Run one case in the calling thread: its thread CPU (user + system) [s], system time [s],
    minor page faults, and the CPU of the whole process over the same interval [s]."""
    from ffsm_pin.scenario.file import scenario_from_toml
    from ffsm_pin.sim.run import prepare, simulate

    t0 = resource.getrusage(resource.RUSAGE_THREAD)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(prepare(scenario_from_toml(scenario_toml)))
    t1 = resource.getrusage(resource.RUSAGE_THREAD)
    return {
        "cpu": t1.ru_utime + t1.ru_stime - t0.ru_utime - t0.ru_stime,
        "sys": t1.ru_stime - t0.ru_stime,
        "minflt": t1.ru_minflt - t0.ru_minflt,
    }


def paired(path: Path, clients: dict) -> None:
    """Per-case CPU of the same cases in this process and on 1-worker clusters, interleaved
    case by case (shuffled order), and the worker processes' CPU outside their cases."""
    from ffsm_pin.sweep.campaign import load_campaign
    from ffsm_pin.sweep.cases import expand

    tomls = [case.scenario_toml for case in expand(load_campaign(path))]
    rows: dict[str, list[dict[str, float]]] = {"this process": [], **{m: [] for m in clients}}
    for c in clients.values():
        c.submit(_one_case, tomls[0], pure=False).result()  # warm
    rng = random.Random(0)
    for toml in tomls:
        order = list(rows)
        rng.shuffle(order)
        for m in order:
            if m == "this process":
                rows[m].append(_one_case(toml))
                continue
            c = clients[m]
            p0 = sum(c.run(_worker_cpu).values())
            row = c.submit(_one_case, toml, pure=False).result()
            row["process"] = sum(c.run(_worker_cpu).values()) - p0
            rows[m].append(row)
    base = [r["cpu"] for r in rows["this process"]]
    print(
        f"\npaired per-case CPU, {len(tomls)} cases, each in turn here and on each 1-worker "
        f"cluster (load average {os.getloadavg()[0]:.2f}):"
    )
    print("| where | case CPU [s] | / here | system [ms] | page faults | worker CPU off the case |")
    print("|---|---|---|---|---|---|")
    for m, v in rows.items():
        cpu = statistics.median(r["cpu"] for r in v)
        ratio = statistics.median(r["cpu"] / b for r, b in zip(v, base, strict=True))
        sys_ms = 1e3 * statistics.median(r["sys"] for r in v)
        flt = statistics.median(r["minflt"] for r in v)
        if "process" in v[0]:
            extra = [(r["process"] - r["cpu"]) for r in v]
            share = statistics.median(e / r["cpu"] for e, r in zip(extra, v, strict=True))
            outside = f"{1e3 * statistics.median(extra):.1f} ms = {100 * share:.1f} %"
        else:
            outside = "-"
        print(f"| {m} | {cpu:.3f} | {ratio:.3f} | {sys_ms:.1f} | {flt:.0f} | {outside} |")


# --------------------------------------------------------------------- --engine
ENGINE_CAMPAIGN = """\
[campaign]
name = "engine-{robot}"
scenario = "{scenario}"
seed = {seed}
repeat = {repeat}
duration = {duration}

[campaign.set]
{extra}
[[vary]]
key = "controller.type"
values = ["lu-jia", "gjm-ct", "adaptive-ct"]
"""
#: robot -> (built-in scenario, [campaign.set] lines): actuators and sensors on, as the
#: compare-controllers campaign runs them (spatial-realistic has its own limits and noise)
ENGINE_ROBOTS = {
    "planar": (
        "case1",
        '"controller.estimates.initial" = "perturbed"\n"actuators.torque_limit" = 100.0\n'
        '"sensors.seed" = 7\n"sensors.noise.joints" = 1e-4\n"sensors.noise.joint_rates" = 1e-3\n'
        '"sensors.noise.base_attitude" = 1e-4\n"sensors.noise.base_rate" = 1e-3\n'
        '"sensors.noise.ee_pose" = 1e-3\n"sensors.noise.ee_velocity" = 1e-3\n',
    ),
    "spatial": ("spatial-realistic", '"controller.estimates.initial" = "perturbed"\n'),
}


def engine_comparison(args) -> None:
    """``--engine``: per simulated step, a 1-worker campaign run in batches (default size, or
    ``--batch-size``) and one case per task (``--batch-size 1``), against the bare Python plant
    loop (bench_run.py's ``py`` baseline) of the same scenario, interleaved per trial."""
    from bench_run import bare_loop

    tmp = Path(tempfile.mkdtemp(prefix="bench_engine_"))
    lc, client, _ = start_cluster(1)
    batched = ("--batch-size", str(args.batch_size)) if args.batch_size else ()
    modes = {"batched": batched, "unbatched": ("--batch-size", "1")}
    per_step: dict[tuple[str, str], list[float]] = {}
    parts: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    try:
        paths = {}
        for robot, (path, warm) in _engine_paths(tmp, args).items():
            paths[robot] = path
            campaign(warm, client, tmp / f"{robot}-warm")  # every controller's kernels loaded
            bare_loop(ENGINE_ROBOTS[robot][0], 0.05)
        for k in range(args.trials):
            for robot, (scenario, _) in ENGINE_ROBOTS.items():
                order = ["bare", *modes]
                order = order[k % 3 :] + order[: k % 3]  # rotated: drifting load hits all
                for m in order:
                    if m == "bare":
                        duration = args.planar_s if robot == "planar" else args.spatial_s
                        b = bare_loop(scenario, duration)
                        step = b["python_wall_time_s"] / b["steps"]
                    else:
                        out = tmp / f"{robot}-{m}-{k}"
                        wall, _ = campaign(paths[robot], client, out, extra=modes[m])
                        rows = pq.read_table(out / "results.parquet").to_pylist()
                        steps = sum(r["steps"] for r in rows)
                        step = wall / steps
                        # the fixed cost (expansion, set-up checks, report): a resume, 0 cases
                        fixed, _ = campaign(paths[robot], client, out, False, modes[m])
                        per_step.setdefault((robot, m + " - fixed"), []).append(
                            (wall - fixed) / steps
                        )
                        cases = sum(r["case_wall_s"] for r in rows)
                        loop = sum(r["wall_time_s"] for r in rows)
                        n = len(rows)
                        parts.setdefault((robot, m), []).append(
                            ((wall - cases) / n, (cases - loop) / n, loop / n)
                        )
                    per_step.setdefault((robot, m), []).append(step)
                print(f"trial {k + 1} {robot}: " + ", ".join(
                    f"{m} {1e6 * per_step[(robot, m)][-1]:.1f} us/step" for m in order
                ), file=sys.stderr)  # fmt: skip
    finally:
        client.close()
        lc.close()
        shutil.rmtree(tmp, ignore_errors=True)
    load = os.getloadavg()
    print(
        f"\nengine: 1 worker, {args.trials} trials, 3 controllers x (1 + {args.engine_repeat}) "
        f"cases, planar {args.planar_s} s, spatial {args.spatial_s} s, batch size "
        f"{args.batch_size or 'default'}; os.cpu_count() = {os.cpu_count()}, load average "
        f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (end)"
    )
    print("| robot | what | per step [us], median | / bare Python loop | per-trial ratios |")
    print("|---|---|---|---|---|")
    for robot in ENGINE_ROBOTS:
        bare = per_step[(robot, "bare")]
        for m in ("bare", *modes, *(f"{m} - fixed" for m in modes)):
            v = per_step[(robot, m)]
            ratios = [a / b for a, b in zip(v, bare, strict=True)]
            print(
                f"| {robot} | {m} | {1e6 * statistics.median(v):.1f} | "
                f"{statistics.median(ratios):.2f}x | {' '.join(f'{r:.2f}' for r in ratios)} |"
            )
        b, u = per_step[(robot, "batched")], per_step[(robot, "unbatched")]
        r = [x / y for x, y in zip(b, u, strict=True)]
        print(f"| {robot} | batched / unbatched | | {statistics.median(r):.3f} | "
              f"{' '.join(f'{x:.3f}' for x in r)} |")  # fmt: skip
    print("\nper case, medians over trials [ms]: campaign outside cases | case outside its "
          "loop (parse, prepare, summary, extras) | the loop")  # fmt: skip
    for (robot, m), v in parts.items():
        cols = [1e3 * statistics.median(x[i] for x in v) for i in range(3)]
        print(f"{robot} {m}: {cols[0]:.0f} | {cols[1]:.0f} | {cols[2]:.0f}")


def _engine_paths(tmp: Path, args) -> dict[str, tuple[Path, Path]]:
    """Per robot, the engine campaign file and its 0.05 s warm-up twin, written in ``tmp``."""
    paths = {}
    for robot, (scenario, extra) in ENGINE_ROBOTS.items():
        duration = args.planar_s if robot == "planar" else args.spatial_s
        text = ENGINE_CAMPAIGN.format(
            robot=robot, scenario=scenario, seed=1, repeat=args.engine_repeat,
            duration=duration, extra=extra,
        )  # fmt: skip
        path, warm = tmp / f"{robot}.toml", tmp / f"{robot}-warm.toml"
        path.write_text(text)
        warm.write_text(text.replace(f"duration = {duration}", "duration = 0.05"))
        paths[robot] = (path, warm)
    return paths


def engine_child(args) -> None:
    """``--engine-child`` (run by ``--baseline``): one trial of the engine campaigns of the tree
    this process imports (:data:`TREE`) on its own warm 1-worker cluster; one JSON line per
    robot: steps, campaign wall time, its fixed part (a resume), the cases' and loops' sums."""
    import json

    tmp = Path(tempfile.mkdtemp(prefix="bench_engine_child_"))
    lc, client, _ = start_cluster(1)
    try:
        paths = _engine_paths(tmp, args)
        for robot, (_, warm) in paths.items():
            campaign(warm, client, tmp / f"{robot}-warm")
        for robot, (path, _) in paths.items():
            out = tmp / robot
            wall, _ = campaign(path, client, out)
            fixed, _ = campaign(path, client, out, False)
            rows = pq.read_table(out / "results.parquet").to_pylist()
            print(json.dumps({
                "robot": robot, "wall": wall, "fixed": fixed, "n": len(rows),
                "steps": sum(r["steps"] for r in rows),
                "cases": sum(r["case_wall_s"] for r in rows),
                "loop": sum(r["wall_time_s"] for r in rows),
            }), flush=True)  # fmt: skip
    finally:
        client.close()
        lc.close()
        shutil.rmtree(tmp, ignore_errors=True)


def engine_against_baseline(args) -> None:
    """``--engine --baseline REV``: the batched engine campaigns of this checkout and of
    ``REV``, one child process per side and trial (:func:`engine_child`), against the bare
    Python plant loop of the same trial in this process."""
    import json
    import subprocess

    from _timing import checkout
    from bench_run import bare_loop

    tmp = Path(tempfile.mkdtemp(prefix="bench_engine_base_"))
    base = tmp / "baseline"
    subprocess.run(["git", "-C", str(HERE.parent), "worktree", "add", "--detach", "-q",
                    str(base), args.baseline], check=True)  # fmt: skip
    sides = {args.baseline: base, "this": HERE.parent}
    child = [sys.executable, str(Path(__file__).resolve()), "--engine-child",
             "--engine-repeat", str(args.engine_repeat), "--planar-s", str(args.planar_s),
             "--spatial-s", str(args.spatial_s)]  # fmt: skip
    got: dict[tuple[str, str], list[dict]] = {}
    bare: dict[str, list[float]] = {}
    load0 = os.getloadavg()
    try:
        for scenario, _ in ENGINE_ROBOTS.values():
            bare_loop(scenario, 0.05)
        for k in range(args.trials):
            order = list(sides)[k % 2 :] + list(sides)[: k % 2]
            for side in order:
                env = {**os.environ, "FFSM_BENCH_TREE": str(sides[side])}
                res = subprocess.run(child, env=env, capture_output=True, text=True, check=True)
                for line in res.stdout.splitlines():
                    if line.startswith("{"):
                        r = json.loads(line)
                        got.setdefault((r["robot"], side), []).append(r)
            for robot, (scenario, _) in ENGINE_ROBOTS.items():
                duration = args.planar_s if robot == "planar" else args.spatial_s
                b = bare_loop(scenario, duration)
                bare.setdefault(robot, []).append(b["python_wall_time_s"] / b["steps"])
            last = {key: v[-1]["wall"] / v[-1]["steps"] for key, v in got.items()}
            print(f"trial {k + 1}: " + ", ".join(
                f"{robot} {side} {1e6 * x:.1f}" for (robot, side), x in last.items()
            ) + " us/step", file=sys.stderr)  # fmt: skip
    finally:
        subprocess.run(["git", "-C", str(HERE.parent), "worktree", "remove", "--force",
                        str(base)], check=False)  # fmt: skip
        shutil.rmtree(tmp, ignore_errors=True)
    load = os.getloadavg()
    print(
        f"\nengine against {args.baseline}: this = {checkout(HERE.parent)}; 1 worker, "
        f"{args.trials} trials, 3 controllers x (1 + {args.engine_repeat}) cases, planar "
        f"{args.planar_s} s, spatial {args.spatial_s} s, batches of the default size; "
        f"os.cpu_count() = {os.cpu_count()}, load average {load0[0]:.2f} (start), "
        f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (end)"
    )
    print("| robot | side | per step [us] | / bare loop | - fixed: per step, / bare | per case "
          "[ms]: outside cases, case outside its loop, the loop |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    med = statistics.median
    for robot in ENGINE_ROBOTS:
        for side in sides:
            v = got[(robot, side)]
            step = [r["wall"] / r["steps"] for r in v]
            nofix = [(r["wall"] - r["fixed"]) / r["steps"] for r in v]
            ratio = [a / b for a, b in zip(step, bare[robot], strict=True)]
            ratio_nf = [a / b for a, b in zip(nofix, bare[robot], strict=True)]
            parts = [med((r["wall"] - r["cases"]) / r["n"] for r in v),
                     med((r["cases"] - r["loop"]) / r["n"] for r in v),
                     med(r["loop"] / r["n"] for r in v)]  # fmt: skip
            per_case = ", ".join(f"{1e3 * x:.0f}" for x in parts)
            print(f"| {robot} | {side} | {1e6 * med(step):.1f} | {med(ratio):.2f}x "
                  f"({' '.join(f'{x:.2f}' for x in ratio)}) | {1e6 * med(nofix):.1f}, "
                  f"{med(ratio_nf):.2f}x | {per_case} |")  # fmt: skip
        a, b = got[(robot, "this")], got[(robot, args.baseline)]
        r = [(x["wall"] / x["steps"]) / (y["wall"] / y["steps"]) for x, y in zip(a, b, strict=True)]
        c = [((x["cases"] - x["loop"]) / x["n"]) / ((y["cases"] - y["loop"]) / y["n"])
             for x, y in zip(a, b, strict=True)]  # fmt: skip
        rs, cs = " ".join(f"{x:.3f}" for x in r), " ".join(f"{x:.3f}" for x in c)
        print(f"| {robot} | this / {args.baseline} | {med(r):.3f} ({rs}) | | | case outside "
              f"its loop: {med(c):.3f} ({cs}) |")  # fmt: skip
    print("bare Python loop per step [us], medians: " + ", ".join(
        f"{robot} {1e6 * med(v):.1f}" for robot, v in bare.items()))  # fmt: skip


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=20, help="cases per trial (default 20)")
    p.add_argument("--trials", type=int, default=3, help="interleaved trials (default 3)")
    p.add_argument("--big", type=int, default=100, help="cases of the big campaign (0: skip)")
    p.add_argument(
        "--paired", type=int, default=10, help="cases of the paired CPU comparison (0: skip)"
    )
    p.add_argument(
        "--engine", action="store_true",
        help="only the engine comparison: batched, unbatched, bare Python plant loop",
    )  # fmt: skip
    p.add_argument("--engine-repeat", type=int, default=2, help="--engine: seeds per controller")
    p.add_argument("--planar-s", type=float, default=5.0, help="--engine: planar duration [s]")
    p.add_argument("--spatial-s", type=float, default=2.0, help="--engine: spatial duration [s]")
    p.add_argument("--batch-size", type=int, default=None, help="--engine: batched size")
    p.add_argument(
        "--baseline", default=None,
        help="--engine: this checkout against a git revision (child processes per side)",
    )  # fmt: skip
    p.add_argument("--engine-child", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.engine_child:
        engine_child(args)
        return 0
    if args.engine and args.baseline:
        engine_against_baseline(args)
        return 0
    if args.engine:
        engine_comparison(args)
        return 0
    n = args.cases

    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    try:
        path = write_campaign(tmp, n, seed=1)
        serial(write_campaign(tmp, 2, seed=99))  # compile / load the kernels here
        if args.paired:
            lcq, cq, _ = start_cluster(1)
            lcd, cd, _ = start_cluster(1, dask_defaults=True)
            paired(
                write_campaign(tmp, args.paired, seed=3),
                {"worker, campaign's cluster": cq, "worker, Dask defaults": cd},
            )
            for x in (cq, lcq, cd, lcd):
                x.close()
        lc2, c2, start2 = start_cluster(2)
        lc1, c1, start1 = start_cluster(1)
        warm = write_campaign(tmp, 3, seed=98)
        warm2 = campaign(warm, c2, tmp / "warm2")[0]  # worker warm-up, reported separately
        warm1 = campaign(warm, c1, tmp / "warm1")[0]
        pool = multiprocessing.get_context("spawn").Pool(2, initializer=_pool_init)
        processes(warm, pool)  # both processes warm before the trials
        runs: dict[str, list[tuple[float, float]]] = {
            "serial": [],
            "2 plain processes": [],
            "2 workers": [],
            "1 worker": [],
            "fixed (resume, 0 cases)": [],
        }
        case_cpu: dict[str, list[float]] = {"2 workers": [], "1 worker": []}
        for k in range(args.trials):
            runs["serial"].append(serial(path))
            runs["2 plain processes"].append(processes(path, pool))
            runs["2 workers"].append(campaign(path, c2, tmp / f"c2-{k}"))
            runs["1 worker"].append(campaign(path, c1, tmp / f"c1-{k}"))
            runs["fixed (resume, 0 cases)"].append(campaign(path, c1, tmp / f"c1-{k}", False))
            for m, folder in (("2 workers", f"c2-{k}"), ("1 worker", f"c1-{k}")):
                table = pq.read_table(tmp / folder / "results.parquet")
                case_cpu[m].append(sum(table.column("case_cpu_s").to_pylist()))
            text = ", ".join(
                f"{m} {v[-1][0]:.2f} s (cpu {v[-1][1]:.2f} s)" for m, v in runs.items()
            )
            print(f"trial {k + 1}: {text}", file=sys.stderr)
        c1.close()
        lc1.close()
        pool.close()
        wall = {m: statistics.median(w for w, _ in v) for m, v in runs.items()}
        cpu = {m: statistics.median(c for _, c in v) for m, v in runs.items()}
        print(
            f"\n{n} cases of 10 s simulated (case 1, spread 0.2), {args.trials} trials, "
            f"os.cpu_count() = {os.cpu_count()}, load average {os.getloadavg()[0]:.2f}"
        )
        print("| what | wall [s] | wall per case [s] | serial / this | CPU [s] | CPU / serial |")
        print("|---|---|---|---|---|---|")
        for m in runs:
            print(
                f"| {m} | {wall[m]:.2f} | {wall[m] / n:.3f} | {wall['serial'] / wall[m]:.2f}x "
                f"| {cpu[m]:.2f} | {cpu[m] / cpu['serial']:.3f} |"
            )
        print(
            f"\nspeed-up, 2 workers vs serial (wall): {wall['serial'] / wall['2 workers']:.2f}x "
            "(target >= 1.8x)"
        )
        steady = wall["serial"] / (wall["2 workers"] - wall["fixed (resume, 0 cases)"])
        print(
            f"the same without the campaign's fixed cost (start, report; paid once per "
            f"campaign): {steady:.2f}x"
        )
        print(
            f"the machine itself, 2 plain processes vs serial (wall): "
            f"{wall['serial'] / wall['2 plain processes']:.2f}x; the campaign on 2 workers "
            f"delivers {wall['2 plain processes'] / wall['2 workers']:.2f} of it; per trial "
            "(serial / processes, serial / 2 workers): "
            + ", ".join(
                f"{s_[0] / p_[0]:.2f} {s_[0] / w_[0]:.2f}"
                for s_, p_, w_ in zip(
                    runs["serial"], runs["2 plain processes"], runs["2 workers"], strict=True
                )
            )
        )
        fixed = "fixed (resume, 0 cases)"
        for label, a, b in (
            ("wall, 1 worker - serial", wall["1 worker"], wall["serial"]),
            ("CPU, 1 worker - serial", cpu["1 worker"], cpu["serial"]),
            ("CPU, 2 workers - serial", cpu["2 workers"], cpu["serial"]),
            ("CPU, 1 worker - serial - fixed", cpu["1 worker"] - cpu[fixed], cpu["serial"]),
            ("CPU, 2 workers - serial - fixed", cpu["2 workers"] - cpu[fixed], cpu["serial"]),
        ):
            over = (a - b) / n
            print(
                f"per-case overhead ({label}): {over * 1e3:.0f} ms = {100 * (a - b) / b:.1f} % "
                "of a 10 s case (target <= 5 %)"
            )
        print(
            f"fixed cost per campaign (resume with nothing to run): {wall[fixed]:.2f} s wall, "
            f"{cpu[fixed]:.2f} s CPU"
        )
        print("\nsame run, CPU of the campaign against the CPU its cases took on the workers:")
        for m in case_cpu:
            ratios = [
                (total - cases) / cases
                for (_, total), cases in zip(runs[m], case_cpu[m], strict=True)
            ]
            no_fixed = [
                (total - f - cases) / cases
                for (_, total), (_, f), cases in zip(runs[m], runs[fixed], case_cpu[m], strict=True)
            ]
            print(
                f"{m}: overhead {100 * statistics.median(ratios):.1f} % of the cases' CPU "
                f"(all included), {100 * statistics.median(no_fixed):.1f} % without the fixed "
                f"per-campaign cost; cases' CPU {statistics.median(case_cpu[m]) / n:.3f} s each"
            )
        print(
            f"cluster start-up: 2 workers {start2:.1f} s, 1 worker {start1:.1f} s; first "
            f"3-case campaign (worker warm-up): {warm2:.1f} s / {warm1:.1f} s"
        )
        if args.big:
            big = write_campaign(tmp, args.big, seed=2)
            w, c = campaign(big, c2, tmp / "big")
            print(
                f"\n{args.big}-case campaign of 10 s cases on 2 workers: {w:.1f} s wall "
                f"({w / args.big:.3f} s per case, CPU {c:.1f} s); 1000 cases at this rate: "
                f"{1000 * w / args.big / 60:.1f} min (wall time only)"
            )
        c2.close()
        lc2.close()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
