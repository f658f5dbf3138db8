"""Runs whose recording cannot be stored are refused before anything is allocated (issue 20)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from ffsm_pin.errors import StorageError
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.run import prepare, recording_size, simulate
from ffsm_pin.sim.storage import check_storage, rows_recorded


@pytest.fixture(scope="module")
def setup():
    return prepare(dataclasses.replace(builtin_scenario("case1"), duration=0.2))


def test_row_size_is_what_a_run_records(setup):
    """bytes per row x rows = the bytes of every per-row signal a run returns."""
    result = simulate(setup, record_every=3)
    steps, row_bytes = recording_size(setup)
    rows = rows_recorded(steps, 3)
    n = len(result["t"])
    per_row = {k: a for k, a in result.signals.items() if np.ndim(a) and len(a) == n}
    assert sum(a.nbytes for a in per_row.values()) == n * row_bytes
    assert n <= rows <= n + 2


@pytest.mark.parametrize("copies", [1, 2])
def test_refusal_names_a_record_every_that_fits(setup, tmp_path, copies):
    steps, row_bytes = recording_size(setup)
    need = copies * rows_recorded(steps, 1) * row_bytes
    disk = need // 10  # a tenth of what it needs
    with pytest.raises(StorageError, match=r"--record-every (\d+)") as exc:
        check_storage(steps, row_bytes, 1, tmp_path, copies=copies, disk=disk)
    assert "free disk" in str(exc.value) and str(tmp_path) in str(exc.value)
    k = int(exc.value.args[0].split("--record-every ")[1].split()[0])
    check_storage(steps, row_bytes, k, tmp_path, copies=copies, disk=disk)  # the suggestion fits
    with pytest.raises(StorageError):  # and is the smallest that does
        check_storage(steps, row_bytes, k - 1, tmp_path, copies=copies, disk=disk)
    check_storage(steps, row_bytes, 1, tmp_path, copies=copies, disk=need)  # enough: no error


def test_simulate_checks_the_spool_folder(setup, tmp_path, monkeypatch):
    """simulate() refuses before stepping when its spool folder's disk cannot hold the rows."""
    from ffsm_pin.sim import storage

    monkeypatch.setattr(storage, "free_disk", lambda folder: 1000)
    with pytest.raises(StorageError, match="free disk"):
        simulate(setup, spool_dir=tmp_path)


@pytest.mark.parametrize("extra", [["--case", "1", "--dt", "1e-7"], ["--duration", "1e9"]])
def test_impossible_requests_are_one_error_line(extra, tmp_path):
    """Both requests of the issue: no traceback, exit 2, nothing written."""
    out = tmp_path / "run"
    args = [sys.executable, "-m", "ffsm_pin.sim", *extra, "--out", str(out), "--quiet"]
    if "--duration" not in extra:
        args += ["--duration", "30"]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "--record-every" in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()
