"""Batches of cases (ffsm_pin.sweep.batches, engine.run_batch): grouped by robot and controller
type, sized by a closed form, and each case of a batch gives exactly the outcome of its single
task, a case that raises included (planar and spatial cases in one batch list). The same end to
end, on a Dask cluster: a campaign run in batches and one case per task write the same rows,
signals and run folders."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pyarrow.parquet as pq
import pytest

from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sweep import cli
from ffsm_pin.sweep.batches import (
    BATCHES_PER_WORKER,
    MAX_BATCH,
    default_batch_size,
    kernel_key,
    make_batches,
    robot_key,
)
from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.cases import expand
from ffsm_pin.sweep.engine import run_batch, run_case, run_cases

# columns and outcome entries that measure the machine, not the run
TIMING = {"wall_time_s", "steps_per_s", "case_wall_s", "case_cpu_s"}

TWO_ROBOTS = """\
[campaign]
name = "two-robots"
scenario = ["case1", "spatial"]
seed = 3
repeat = 1
duration = {duration}

[campaign.set]
"controller.estimates.initial" = "perturbed"

[[vary]]
key = "controller.type"
values = ["lu-jia", "gjm-ct", "adaptive-ct"]
"""


def test_default_batch_size_closed_form():
    for workers in (1, 2, 3, 8):
        for n in range(0, 400, 7):
            size = default_batch_size(n, workers)
            assert 1 <= size <= MAX_BATCH
            want = -(-n // (BATCHES_PER_WORKER * workers))  # ceil
            assert size == min(MAX_BATCH, max(1, want))
            if size < MAX_BATCH and n > 0:  # the fewest cases a batch that make at most
                k = BATCHES_PER_WORKER * workers  # BATCHES_PER_WORKER batches per worker
                assert -(-n // size) <= k
                assert size == 1 or -(-n // (size - 1)) > k
    assert default_batch_size(151, 2) == MAX_BATCH  # compare-controllers on 2 workers
    assert default_batch_size(5, 0) == default_batch_size(5, 1)


@pytest.mark.parametrize("size", [1, 2, 3, 5, 100])
def test_batches_group_cases_by_robot_and_controller(campaign_file, size):
    """Every case once, in the order given within a batch; a batch of one robot and one
    controller type (a batch that straddles two types leaves a case alone at its cut, out of
    lock-step); a robot's batches together; each (robot, controller) group cut into the
    fewest batches of at most ``size``."""
    cases = expand(load_campaign(campaign_file(TWO_ROBOTS.format(duration=0.1))))
    shuffled = cases[1::2] + cases[0::2]  # the robots interleaved
    batches = make_batches(shuffled, size)
    flat = [c.index for b in batches for c in b]
    assert sorted(flat) == [c.index for c in cases]  # every case once
    for b in batches:
        assert 1 <= len(b) <= size
        assert len({kernel_key(c) for c in b}) == 1
        order = [shuffled.index(c) for c in b]
        assert order == sorted(order)  # in the order given
    keys = [robot_key(b[0]) for b in batches]
    assert keys == sorted(keys, key=keys.index) and len(set(keys)) == 2  # robots not mixed
    per_robot = {k: sum(len(b) for b in batches if robot_key(b[0]) == k) for k in set(keys)}
    assert sorted(per_robot.values()) == [4, 4]
    per_kernel: dict = {}
    for c in cases:
        per_kernel[kernel_key(c)] = per_kernel.get(kernel_key(c), 0) + 1
    assert len(per_kernel) == 6  # two robots x three controller types
    assert len(batches) == sum(-(-n // size) for n in per_kernel.values())


def _short(name: str, **changes) -> str:
    sc = builtin_scenario(name)
    return scenario_to_toml(dataclasses.replace(sc, duration=30 * sc.dt, **changes))


def _same(a: dict, b: dict) -> bool:
    """Outcomes equal on everything but timing, the signals' arrays bit for bit."""
    if {k for k in a if k not in TIMING} != {k for k in b if k not in TIMING}:
        return False
    for key in a:
        if key in TIMING:
            continue
        if key == "signals":
            if a[key].keys() != b[key].keys() or not all(
                np.array_equal(a[key][s], b[key][s]) for s in a[key]
            ):
                return False
        elif a[key] != b[key]:
            return False
    return True


def test_each_case_of_a_batch_is_its_single_task(monkeypatch):
    """The cases lock-step takes run together (the three planar lu-jia cases, the two spatial
    ones: ffsm_pin.sim.lockstep), the others alone; each outcome is its single task's."""
    import ffsm_pin.sim.lockstep as lockstep

    together: list[int] = []
    original = lockstep.simulate_lockstep

    def counted(setups, **kwargs):
        together.append(len(setups))
        return original(setups, **kwargs)

    monkeypatch.setattr(lockstep, "simulate_lockstep", counted)
    planar = _short("case1").replace('initial = "paper"', 'initial = "perturbed"')
    seeded = planar.replace("seed = 0", "seed = 5", 1)  # other estimates
    spatial = _short("spatial")
    narrow = planar.replace("rho_z0 = [1.0, 1.0, 0.2]", "rho_z0 = [0.1, 0.1, 0.2]")
    sc = builtin_scenario("case1")
    missing = _short("case1", robot=dataclasses.replace(sc.robot, urdf="no-such-robot.urdf"))
    assert seeded != planar and narrow != planar
    tomls = [planar, narrow, spatial, missing, seeded, spatial, planar]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        batch = run_batch(tomls)
        alone = [run_case(t) for t in tomls]
    assert sorted(together) == [2, 3]  # (the narrow funnel's and the missing robot's alone)
    assert [o["status"] for o in batch] == [o["status"] for o in alone]
    assert batch[1]["status"] == batch[3]["status"] == "error"
    assert "not strictly inside its funnel" in batch[1]["error"]
    assert "no-such-robot.urdf" in batch[3]["error"]
    assert all(o["status"] != "error" for i, o in enumerate(batch) if i not in (1, 3))
    for got, want in zip(batch, alone, strict=True):
        assert _same(got, want), (got.get("error"), want.get("error"))
    assert _same(batch[0], batch[6]) and not _same(batch[0], batch[4])  # a fresh case each time


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    with warnings.catch_warnings():  # "port 8787 in use" if another cluster runs: harmless
        warnings.simplefilter("ignore")
        lc = LocalCluster(
            n_workers=2, threads_per_worker=1, dashboard_address=None, silence_logs=50
        )
    with lc, Client(lc):
        yield lc.scheduler_address


class _Recording:
    """A Dask client that records what is submitted to it (function, arguments, options)."""

    def __init__(self, client):
        self.client, self.submitted = client, []

    def submit(self, fn, *args, **kwargs):
        future = self.client.submit(fn, *args, **kwargs)
        self.submitted.append((fn, args, kwargs, future))
        return future

    def __getattr__(self, name):
        return getattr(self.client, name)


def test_each_controller_and_robot_is_warmed_once_before_its_batches(cluster, campaign_file):
    from distributed import Client

    from ffsm_pin.sweep.engine import warm_up

    cases = expand(load_campaign(campaign_file(TWO_ROBOTS.format(duration=0.05))))
    keys = [kernel_key(c) for c in cases]
    assert len(set(keys)) == 6  # 2 robots x 3 controllers
    with Client(cluster) as real:
        client = _Recording(real)
        outcomes = [o for _, o in run_cases(client, cases, batch_size=3)]  # type: ignore[arg-type]
        warm = [(args, kw, f) for fn, args, kw, f in client.submitted if fn is warm_up]
        batches = [(args, f) for fn, args, _, f in client.submitted if fn is run_batch]
        assert all(f.status == "finished" for _, _, f in warm)  # (a warm-up never raises)
    assert len(outcomes) == len(cases) and all(o["status"] != "error" for o in outcomes)
    # one warm-up per robot and controller, of its first case, submitted before every batch
    # and ahead of them (priority)
    first = {k: cases[keys.index(k)] for k in dict.fromkeys(keys)}
    assert [args[0] for args, _, _ in warm] == [c.scenario_toml for c in first.values()]
    assert all(kw["priority"] > 0 for _, kw, _ in warm)
    assert [fn for fn, *_ in client.submitted[: len(warm)]] == [warm_up] * len(warm)
    by_toml = {c.scenario_toml: k for c, k in zip(cases, keys, strict=True)}
    warm_of = {by_toml[args[0]]: f.key for args, _, f in warm}
    # each batch waits for exactly the warm-ups of its cases' robots and controllers
    assert sum(len(args[0]) for args, _ in batches) == len(cases)
    for (tomls, _, after), _ in batches:
        assert sorted(f.key for f in after) == sorted({warm_of[by_toml[t]] for t in tomls})


@pytest.mark.slow
def test_a_campaign_in_batches_writes_what_single_tasks_write(cluster, campaign_file, tmp_path):
    path = campaign_file(TWO_ROBOTS.format(duration=0.3))
    runs = {}
    for size in ("1", "3"):
        out = tmp_path / f"size{size}"
        argv = [str(path), "--out", str(out), "--scheduler", cluster, "--quiet", "--keep-runs"]
        assert cli.main([*argv, "--batch-size", size]) == 0
        runs[size] = out
    rows = {k: pq.read_table(v / "results.parquet").to_pylist() for k, v in runs.items()}
    assert len(rows["1"]) == len(rows["3"]) == 8
    for a, b in zip(rows["1"], rows["3"], strict=True):
        assert {k: v for k, v in a.items() if k not in TIMING} == {
            k: v for k, v in b.items() if k not in TIMING
        }
    signals = {  # in the order the cases finished: compared case by case
        k: pq.read_table(v / "signals.parquet").sort_by([("case", "ascending"), ("t", "ascending")])
        for k, v in runs.items()
    }
    assert signals["1"].num_rows > 0 and signals["1"].equals(signals["3"])
    for r in rows["1"]:
        folder = f"case-{r['case']:05d}"
        with (
            np.load(runs["1"] / "runs" / folder / "trajectory.npz") as a,
            np.load(runs["3"] / "runs" / folder / "trajectory.npz") as b,
        ):
            assert a.files == b.files and len(a.files) > 10
            for key in a.files:
                assert np.array_equal(a[key], b[key], equal_nan=True), (folder, key)
