"""One campaign at a time per output folder, and a quiet Ctrl-C (docs/campaigns.md, "Exit
status and what is kept").

Campaign processes run as ``python -m ffsm_pin.sweep`` does from a terminal, in a session of
their own so that a Ctrl-C reaches the whole process group, workers included, as the terminal
sends it. The campaigns are small versions of ``sweep_cases.SMALL``.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from sweep_cases import SMALL

from ffsm_pin.sweep import cli
from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.cases import expand
from ffsm_pin.sweep.folder import (
    LOCK_FILE,
    CampaignFolderError,
    CampaignIdentity,
    FolderInUseError,
    FolderLock,
    folder_campaign,
)

REPO = Path(__file__).resolve().parents[2]
TINY = SMALL.replace("[0.1, 0.3]", "[0.1]").replace("repeat = 2", "repeat = 1")  # 2 cases
# 5 cases of 8 s: a campaign on one worker that runs long enough to be met while running
LONGER = SMALL.replace("duration = 4.0", "duration = 8.0")
# 41 cases: a Ctrl-C after the first row on disk always finds cases left (a case takes ~0.3 s
# with a warm compile cache)
MANY = LONGER.replace("repeat = 2", "repeat = 20")


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    with warnings.catch_warnings():  # "port 8787 in use" if another cluster runs: harmless
        warnings.simplefilter("ignore")
        lc = LocalCluster(
            n_workers=1, threads_per_worker=1, dashboard_address=None, silence_logs=50
        )
    with lc, Client(lc):
        yield lc.scheduler_address


def _as_in_a_terminal() -> None:
    """SIGINT as a terminal's foreground command has it: default and unblocked. A test run
    started in the background by a non-interactive shell (``cmd &``, as a CI script may)
    ignores SIGINT, and a child inherits that: the campaign would never see the Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def start(campaign: Path, out: Path, *extra: str) -> subprocess.Popen:
    """``python -m ffsm_pin.sweep CAMPAIGN --out OUT ...`` in a session of its own, with SIGINT
    as in a terminal."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.Popen(
        [sys.executable, "-m", "ffsm_pin.sweep", str(campaign), "--out", str(out), *extra],
        cwd=campaign.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, start_new_session=True, preexec_fn=_as_in_a_terminal,
    )  # fmt: skip


def wait_for(check: Callable[[], bool], proc: subprocess.Popen, what: str, timeout=180.0):
    deadline = time.monotonic() + timeout
    while not check():
        if proc.poll() is not None:
            raise AssertionError(f"the campaign ended before {what}: {proc.communicate()}")
        if time.monotonic() > deadline:
            proc.kill()
            raise AssertionError(f"no {what} within {timeout} s")
        time.sleep(0.05)


def lock_names_pid(out: Path, pid: int) -> bool:
    try:
        return f'"pid": {pid}' in (out / LOCK_FILE).read_text()
    except FileNotFoundError:
        return False


def finished_rows(out: Path) -> int:
    try:
        return pq.read_table(out / "results.parquet").num_rows
    except (FileNotFoundError, OSError):
        return 0


def lines(stderr: str) -> list[str]:
    """stderr's lines without the progress bar (lines redrawn with carriage returns)."""
    return [s for line in stderr.splitlines() if (s := line.split("\r")[-1].strip())]


def case_hashes(out: Path) -> list[str]:
    return sorted(pq.read_table(out / "results.parquet").column("case_hash").to_pylist())


def test_a_second_campaign_into_a_running_folder_is_refused(campaign_file, tmp_path, cluster):
    """The same campaign started twice into one folder: the second gets one error line naming
    the folder and the first one's pid (exit 2), writes nothing; the first finishes with every
    case exactly once."""
    path = campaign_file(LONGER)
    out = tmp_path / "out"
    first = start(path, out, "--scheduler", cluster, "--quiet")
    try:
        # results.parquet is written when the campaign starts (after it took the lock)
        wait_for((out / "results.parquet").is_file, first, "results.parquet")
        second = subprocess.run(
            [sys.executable, "-m", "ffsm_pin.sweep", str(path), "--out", str(out),
             "--scheduler", cluster],
            cwd=tmp_path, capture_output=True, text=True, timeout=300,
            env={**os.environ, "PYTHONPATH": str(REPO)},
        )  # fmt: skip
        running = first.poll() is None  # else the second one may have come too late
        assert second.returncode == cli.EXIT_BAD_INPUT, (second.stderr, running)
        assert running, "the first campaign ended before the second one was refused"
        (line,) = lines(second.stderr)
        assert line.startswith("error: ") and str(out) in line and f"pid {first.pid}" in line
        assert second.stdout == ""
        stdout, stderr = first.communicate(timeout=300)
    finally:
        first.kill()
    assert first.returncode == 0, stderr
    assert stdout.strip() == str(out)
    assert case_hashes(out) == sorted(c.case_hash for c in expand(load_campaign(path)))
    assert not (out / LOCK_FILE).exists()


def test_a_stale_lock_of_a_killed_campaign_is_taken_over(campaign_file, tmp_path, cluster):
    """A lock file left by a process killed with SIGKILL while holding it (and a temporary
    results file it was writing): taken over with one warning naming the old pid."""
    path = campaign_file(TINY)
    out = tmp_path / "out"
    code = (
        "import sys, time; from pathlib import Path; from ffsm_pin.sweep.folder import FolderLock;"
        "lock = FolderLock(Path(sys.argv[1]), 'ghost').acquire(); print('locked', flush=True);"
        "time.sleep(600)"
    )
    ghost = subprocess.Popen(
        [sys.executable, "-c", code, str(out)], stdout=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )  # fmt: skip
    try:
        assert ghost.stdout is not None and ghost.stdout.readline().strip() == "locked"
        with pytest.raises(FolderInUseError, match=f"pid {ghost.pid} "):
            FolderLock(out).acquire()
    finally:
        ghost.kill()
        ghost.wait(timeout=60)
    assert lock_names_pid(out, ghost.pid)  # the file is still there, but nobody holds it
    leftover = out / f".results.parquet.{ghost.pid}.tmp"
    leftover.write_bytes(b"half a parquet file")

    proc = start(path, out, "--scheduler", cluster)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    warnings_ = [s for s in lines(stderr) if s.startswith("warning:")]
    assert len(warnings_) == 1 and f"pid {ghost.pid} " in warnings_[0], stderr
    assert not [s for s in lines(stderr) if s.startswith("error")]
    assert case_hashes(out) == sorted(c.case_hash for c in expand(load_campaign(path)))
    assert not leftover.exists() and not (out / LOCK_FILE).exists()


def sweep(campaign: Path, out: Path, address: str, *extra: str) -> int:
    return cli.main([str(campaign), "--out", str(out), "--scheduler", address, *extra])


def test_a_folder_of_another_campaign_needs_force(campaign_file, tmp_path, cluster, capsys):
    """A campaign of another name into a folder that holds one: exit 2 with one line naming
    both and --force, nothing changed; with --force it runs, the other's files kept."""
    small = campaign_file(TINY, "small.toml")
    other = campaign_file(TINY.replace('name = "small"', 'name = "other"'), "other.toml")
    out = tmp_path / "out"
    assert sweep(small, out, cluster, "--quiet") == 0
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}

    assert sweep(other, out, cluster) == cli.EXIT_BAD_INPUT
    captured = capsys.readouterr()
    (line,) = lines(captured.err)
    assert line.startswith("error: ") and str(out) in line
    assert "'small'" in line and "'other'" in line and "--force" in line
    assert captured.out == ""
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before

    assert sweep(other, out, cluster, "--force") == 0
    (old_results,) = out.glob("results-before-*.parquet")
    (old_campaign,) = out.glob("campaign-before-*.toml")
    assert old_results.read_bytes() == before["results.parquet"]
    assert old_campaign.read_bytes() == before["campaign.toml"]
    assert folder_campaign(out) == CampaignIdentity("other", ("case1",))
    (warning,) = [s for s in lines(capsys.readouterr().err) if s.startswith("warning:")]
    assert old_results.name in warning and old_campaign.name in warning

    # the folder's campaign again, resumed: its own file is accepted
    assert sweep(other, out, cluster, "--quiet") == 0
    assert capsys.readouterr().err == ""


def test_campaign_identity_of_a_folder(tmp_path):
    """Name and scenario list (in any order) make a campaign's identity; a campaign file
    without a name is known by the name in campaign.toml's first line."""
    (tmp_path / "campaign.toml").write_text(
        '# campaign "gains" from gains.toml, as run by python -m ffsm_pin.sweep\n'
        '[campaign]\nscenario = ["case1", "planar5"]\n'
    )
    held = folder_campaign(tmp_path)
    assert held == CampaignIdentity("gains", ("case1", "planar5"))
    assert held.same_as(CampaignIdentity("gains", ("planar5", "case1")))
    assert not held.same_as(CampaignIdentity("gains", ("case1",)))
    assert not held.same_as(CampaignIdentity("gain", ("case1", "planar5")))
    (tmp_path / "campaign.toml").write_text("[campaign\n")
    with pytest.raises(CampaignFolderError, match="is not a campaign file"):
        folder_campaign(tmp_path)
    assert folder_campaign(tmp_path / "nothing") is None


def test_ctrl_c_stops_quietly_and_keeps_the_rows(campaign_file, tmp_path):
    """Ctrl-C, as a terminal sends it (SIGINT to every process of the campaign, Dask's
    workers included), once a row is on disk: exit 130, one line and no traceback of Dask or
    its workers, a readable results.parquet, no lock left."""
    path = campaign_file(MANY)
    out = tmp_path / "out"
    proc = start(path, out, "--workers", "1")
    try:
        wait_for(lambda: finished_rows(out) >= 1, proc, "finished row")
        os.killpg(proc.pid, signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == cli.EXIT_INTERRUPTED, stderr
    for word in ("Traceback", "CancelledError", "CommClosedError", "KeyboardInterrupt"):
        assert word not in stderr, stderr
    progress = re.compile(r"^small: +\d+%")  # the progress bar, redrawn
    assert [s for s in lines(stderr) if not progress.match(s)] == [
        f"interrupted; finished rows are in {out / 'results.parquet'}"
    ]
    assert stdout == ""
    rows = pq.read_table(out / "results.parquet").to_pylist()
    hashes = [r["case_hash"] for r in rows]
    assert 1 <= len(rows) < 41 and len(set(hashes)) == len(hashes)
    assert all(r["status"] in ("completed", "stopped") for r in rows)
    assert not (out / LOCK_FILE).exists()
