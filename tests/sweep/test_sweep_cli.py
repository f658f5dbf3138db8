"""Campaigns end to end on a LocalCluster of 2 single-threaded workers (4 s cases).

Each row equals a single run of the same case through ``python -m ffsm_pin.sim`` (bitwise on
the summary numbers); resuming runs nothing twice; a grid extended by a value runs only the
new cases; a worker killed mid-campaign leaves every case with exactly one row; a case whose
run raises gets an ``error`` row and exit status 3.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from sweep_cases import SMALL

from ffsm_pin.sweep import cli
from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.cases import expand

pytestmark = pytest.mark.slow
REPO = Path(__file__).resolve().parents[2]
# summary.json entries that measure the machine, not the run
TIMING = {"wall_time_s", "steps_per_s"}


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    with warnings.catch_warnings():  # "port 8787 in use" if another cluster runs: harmless
        warnings.simplefilter("ignore")
        lc = LocalCluster(
            n_workers=2, threads_per_worker=1, dashboard_address=None, silence_logs=50
        )
    with lc, Client(lc) as client:
        yield lc.scheduler_address, client


def sweep(campaign: Path, out: Path, address: str, *extra: str) -> int:
    return cli.main([str(campaign), "--out", str(out), "--scheduler", address, "--quiet", *extra])


def rows(out: Path) -> list[dict]:
    return pq.read_table(out / "results.parquet").to_pylist()


def single_run(scenario_toml: str, tmp: Path) -> dict:
    """The same case through ``python -m ffsm_pin.sim``, as a user re-runs it."""
    tmp.mkdir()
    (tmp / "case.toml").write_text(scenario_toml)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--scenario", "case.toml", "--no-plots",
         "--no-html", "--quiet", "--out", "run"],
        cwd=tmp, capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip
    assert proc.returncode in (0, 3), proc.stderr
    return json.loads((tmp / "run" / "summary.json").read_text())


def test_campaign_rows_resume_and_extension(cluster, campaign_file, tmp_path, capsys):
    address, _ = cluster
    path = campaign_file(SMALL)
    out = tmp_path / "out"
    assert sweep(path, out, address) == 0
    assert capsys.readouterr().out.strip() == str(out)
    first = rows(out)
    cases = expand(load_campaign(path))
    assert [r["case"] for r in first] == [0, 1, 2, 3, 4]
    assert [r["case_hash"] for r in first] == [c.case_hash for c in cases]
    for col in ("case", "case_hash", "controller.estimates.spread", "estimates_seed", "status",
                "error", "funnel_ok_b", "funnel_ok_z", "first_violation_t", "max_abs_u",
                "drift_P", "drift_L", "settle_time_b", "settle_time_z", "min_sigma", "completed",
                "stop_reason", "wall_time_s"):  # fmt: skip
        assert col in first[0], col
    assert all(r["status"] in ("completed", "stopped") for r in first)
    assert {"results.parquet", "campaign.toml", "report.md", "fig_funnel_rate.png"} <= {
        p.name for p in out.iterdir()
    }

    # each row equals a single run of the same case (bitwise on every summary scalar)
    for r in (first[0], first[3]):
        summary = single_run(r["scenario_toml"], tmp_path / f"single{r['case']}")
        scalars = {
            k: v for k, v in summary.items()
            if k not in TIMING and (v is None or isinstance(v, (bool, int, float, str)))
        }  # fmt: skip
        assert len(scalars) > 15
        for key, value in scalars.items():
            assert r[key] == value, (r["case"], key, r[key], value)
        assert r["status"] == ("completed" if summary["completed"] else "stopped")

    # resume: nothing runs again (the rows, their wall times included, are unchanged)
    assert sweep(path, out, address) == 0
    assert rows(out) == first

    # one more spread: only its 2 cases run; the earlier rows are kept as they were
    wider = campaign_file(SMALL.replace("[0.1, 0.3]", "[0.1, 0.2, 0.3]"), "wider.toml")
    assert sweep(wider, out, address) == 0
    after = rows(out)
    assert len(after) == 7
    old = {r["case_hash"]: r for r in first}
    kept = [r for r in after if r["case_hash"] in old]
    assert len(kept) == 5
    for r in kept:
        assert {k: v for k, v in r.items() if k not in ("case", "grid_point")} == {
            k: v for k, v in old[r["case_hash"]].items() if k not in ("case", "grid_point")
        }
    new = [r for r in after if r["case_hash"] not in old]
    assert [r["controller.estimates.spread"] for r in new] == [0.2, 0.2]
    assert [r["case"] for r in after] == list(range(7))

    # back to the narrower grid: nothing runs, the 0.2 rows are left out, the old file kept
    assert sweep(path, out, address) == 0
    assert [r["case_hash"] for r in rows(out)] == [r["case_hash"] for r in first]
    (before,) = out.glob("results-before-*.parquet")
    assert pq.read_table(before).num_rows == 7

    # --force runs everything again (new wall times)
    assert sweep(wider, out, address, "--force") == 0
    forced = rows(out)
    assert len(forced) == 7 and [r["case_hash"] for r in forced] == [r["case_hash"] for r in after]
    assert any(a["wall_time_s"] != b["wall_time_s"] for a, b in zip(after, forced, strict=True))


def test_worker_killed_mid_campaign(cluster, campaign_file, tmp_path):
    """SIGKILL one worker once the first row is written: the scheduler re-runs its task on a
    worker (the nanny restarts the dead one) and every case still has exactly one row."""
    address, client = cluster
    text = SMALL.replace("repeat = 2", "repeat = 5").replace("dt = 0.002", "dt = 0.001")
    path = campaign_file(text)
    out = tmp_path / "out"
    pids = client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killed = threading.Event()

    def killer():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            try:
                if len(pq.read_table(out / "results.parquet").to_pylist()) >= 2:
                    os.kill(victim, signal.SIGKILL)
                    killed.set()
                    return
            except (FileNotFoundError, OSError):
                pass
            time.sleep(0.05)

    thread = threading.Thread(target=killer, daemon=True)
    thread.start()
    status = sweep(path, out, address)
    thread.join()
    assert killed.is_set()
    got = rows(out)
    cases = expand(load_campaign(path))
    assert sorted(r["case_hash"] for r in got) == sorted(c.case_hash for c in cases)
    assert len(got) == len(cases) == 11
    assert status == 0 and all(r["status"] != "error" for r in got), [r["error"] for r in got]
    client.wait_for_workers(2, timeout=60)
    assert victim not in client.run(os.getpid).values()


def test_a_failure_of_the_cluster_around_a_case_runs_it_again(
    cluster, campaign_file, tmp_path, monkeypatch
):
    """An exception from a case's future that is not the case's own (run_case returns those
    as rows) and not KilledWorker, as an asyncio object bound to a dead worker's loop seen
    under load in test_worker_killed_mid_campaign: the case is submitted once more and its
    row is a run, not an error."""
    from distributed.client import Future

    address, _ = cluster
    path = campaign_file(SMALL)
    out = tmp_path / "out"
    real = Future.result
    failed: list[str] = []

    def result_failing_once(self, *args, **kwargs):
        if not failed:
            failed.append(self.key)
            raise RuntimeError("<asyncio.locks.Event object> is bound to a different event loop")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Future, "result", result_failing_once)
    assert sweep(path, out, address) == 0
    got = rows(out)
    cases = expand(load_campaign(path))
    assert failed and sorted(r["case_hash"] for r in got) == sorted(c.case_hash for c in cases)
    assert all(r["status"] != "error" for r in got), [r["error"] for r in got]


def test_a_case_that_raises_is_an_error_row(cluster, campaign_file, tmp_path, capsys):
    """rho_z0 sampled per case: the first case of the grid point passes the set-up check, a
    later one draws a funnel too narrow for the initial error (-0.23, 0.48, 0.07) and its run
    raises on the worker: an ``error`` row with the message, the others complete, exit 3."""
    address, _ = cluster
    base = SMALL.replace("[0.1, 0.3]", "[0.1]").replace("repeat = 2", "repeat = 4")
    sample = (
        '[[sample]]\nkey = "controller.funnel.rho_z0"\ndistribution = "uniform"\n'
        "low = 0.3\nhigh = 1.2\n"
    )
    for seed in range(100):  # a root seed whose first draw is wide enough and a later one not
        text = base.replace("seed = 11", f"seed = {seed}") + sample
        cases = expand(load_campaign(campaign_file(text)))
        # one column type: lists, since case 0's rho_z0 = [1.0, 1.0, 0.2] is
        rho = [c.values["controller.funnel.rho_z0"][0] for c in cases[1:]]
        if rho[0] > 0.6 and min(rho[1:]) < 0.45:
            break
    out = tmp_path / "out"
    assert sweep(campaign_file(text), out, address) == 3
    got = {r["case"]: r for r in rows(out)}
    assert len(got) == 5
    for case in cases[1:]:
        r = got[case.index]
        rho_z0 = case.values["controller.funnel.rho_z0"][0]
        if rho_z0 < 0.45:
            assert r["status"] == "error" and "not strictly inside its funnel" in r["error"]
            assert r["max_abs_u"] is None
        elif rho_z0 > 0.5:
            assert r["status"] in ("completed", "stopped") and r["error"] is None
    assert "RuntimeError" not in capsys.readouterr().err


def test_keep_runs_writes_each_run_folder(cluster, campaign_file, tmp_path):
    """--keep-runs: runs/case-NNNNN/ as python -m ffsm_pin.sim writes it, matching the row."""
    address, _ = cluster
    text = SMALL.replace("[0.1, 0.3]", "[0.2]").replace("repeat = 2", "repeat = 1")
    out = tmp_path / "out"
    assert sweep(campaign_file(text), out, address, "--keep-runs") == 0
    got = rows(out)
    assert len(got) == 2
    for r in got:
        folder = out / "runs" / f"case-{r['case']:05d}"
        for name in ("trajectory.npz", "summary.json", "scenario.toml", "replay.html"):
            assert (folder / name).is_file(), name
        summary = json.loads((folder / "summary.json").read_text())
        assert summary["max_abs_u"] == r["max_abs_u"] and summary["steps"] == r["steps"]


def test_an_interrupted_campaign_keeps_every_finished_row(campaign_file, tmp_path, monkeypatch):
    """Ctrl-C after 3 finished cases (rewrites throttled, so not yet on disk): the final
    flush writes all 3 rows; a resume runs only the others."""
    from ffsm_pin.sweep import engine

    path = campaign_file(SMALL)
    cases = expand(load_campaign(path))
    done = {"status": "completed", "error": None, "max_abs_u": 1.0}

    def three_then_interrupt(client, todo, keep, batch_size=None):
        for case in todo[:3]:
            yield case, done
        raise KeyboardInterrupt

    class FakeClient:
        def close(self):
            pass

    monkeypatch.setattr(engine, "start_client", lambda *a, **k: (FakeClient(), None))
    monkeypatch.setattr(engine, "run_cases", three_then_interrupt)
    out = tmp_path / "out"
    assert cli.main([str(path), "--out", str(out), "--quiet"]) == cli.EXIT_INTERRUPTED
    got = rows(out)
    assert sorted(r["case_hash"] for r in got) == sorted(c.case_hash for c in cases[:3])
    seen = []

    def record(client, todo, keep, batch_size=None):
        seen.extend(todo)
        yield from ((c, done) for c in todo)

    monkeypatch.setattr(engine, "run_cases", record)
    assert cli.main([str(path), "--out", str(out), "--quiet"]) == 0
    assert [c.case_hash for c in seen] == [c.case_hash for c in cases[3:]]
    assert len(rows(out)) == len(cases)
