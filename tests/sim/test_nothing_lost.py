"""Nothing lost, nothing corrupted (docs/cli.md, "What is kept when something fails").

A run's files replace an earlier run's as a whole and only once complete (a full disk, a file-
size limit, Ctrl-C during the write); a killed run's spool becomes a readable run with
``--recover``; a controller cannot change the recorded truth, and whatever it does (exit,
return a non-number, a signal of a new type) stops the run cleanly with everything written.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.errors import OutputError
from ffsm_pin.scenario.file import load_scenario
from ffsm_pin.sim import files as files_module
from ffsm_pin.sim import result as result_module
from ffsm_pin.sim.files import RunFolder, strict_json
from ffsm_pin.sim.outputs import write_outputs
from ffsm_pin.sim.result import CONTRACT_KEYS
from ffsm_pin.sim.run import prepare, simulate

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "joint_pd_planar.toml"


def _cli(*args: str, env_extra: dict | None = None, **kw) -> subprocess.CompletedProcess:
    env = {**os.environ, **(env_extra or {})}
    return subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", *args],
        capture_output=True, text=True, env=env, cwd=kw.pop("cwd", ROOT), **kw,
    )  # fmt: skip


def _error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.strip()]


def _controller_scenario(tmp_path: Path, body: str, name: str = "ctrl") -> Path:
    """A copy of the example's planar scenario whose controller is the class ``C`` of
    ``body`` (a Python module), in ``tmp_path``."""
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(body))
    text = EXAMPLE.read_text().replace('"joint_pd.py:JointPD"', f'"{name}.py:C"')
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


PD = """
import numpy as np

class C:
    def __init__(self, ctx):
        self.target = np.array(ctx.initial.q_m, dtype=float)
        self.m3 = ctx.m3

    def torque(self, meas):
        return 5.0 * (self.target - meas.q_m) - 2.0 * meas.w[self.m3:]
"""


# --------------------------------------------------------------------- atomic outputs
def _earlier_run(folder: Path) -> dict[str, bytes]:
    """Run case 1 briefly into ``folder``; the bytes of its files."""
    done = _cli("--case", "1", "--duration", "0.05", "--no-html", "--out", str(folder))
    assert done.returncode == 0, done.stderr
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def _unchanged(folder: Path, before: dict[str, bytes]) -> None:
    now = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    assert now == before
    assert not [p for p in folder.iterdir() if p.name.startswith(".ffsm-")]  # nothing left over


def test_a_failed_write_keeps_the_earlier_run(tmp_path, monkeypatch):
    """A disk that fills while trajectory.npz is written: the error names the file, and the
    folder holds the earlier run byte for byte (no truncated npz, no staging left)."""
    folder = tmp_path / "run"
    before = _earlier_run(folder)
    assert {"trajectory.npz", "summary.json", "scenario.toml", "fig_errors.png"} <= set(before)
    result = simulate(prepare(_short(EXAMPLE)))
    real = result_module.write_npz

    def full_disk(path, signals, compress=False):
        real(path, {k: signals[k] for k in ("t", "q")}, compress)  # part of it reaches the disk
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(result_module, "write_npz", full_disk)
    with pytest.raises(OutputError, match="trajectory.npz.*No space left on device"):
        write_outputs(folder, result, figures=True)
    _unchanged(folder, before)


def _short(path: Path, duration: float = 0.05):
    import dataclasses

    return dataclasses.replace(load_scenario(path), duration=duration)


def test_a_new_run_replaces_the_earlier_one_as_a_whole(tmp_path):
    """A run without figures into a folder holding a run with figures: the earlier figures
    and replay are gone, the new files are the new run's."""
    folder = tmp_path / "run"
    _earlier_run(folder)
    (folder / "replay.html").write_text("<html>an earlier replay</html>")
    (folder / "notes.txt").write_text("the user's own file")
    done = _cli("--case", "2", "--duration", "0.05", "--no-plots", "--no-html", "--out",
                str(folder))  # fmt: skip
    assert done.returncode == 0, done.stderr
    names = {p.name for p in folder.iterdir()}
    assert names == {"trajectory.npz", "summary.json", "scenario.toml", "notes.txt"}
    assert json.loads((folder / "summary.json").read_text())["scenario"] == "case2"
    assert 'name = "case2"' in (folder / "scenario.toml").read_text()


def test_a_file_size_limit_is_refused_before_the_run_and_keeps_the_earlier_one(tmp_path):
    """RLIMIT_FSIZE (``ulimit -f``) smaller than the run's trajectory.npz: one error line
    naming the limit and a --record-every that fits, before anything is simulated."""
    folder = tmp_path / "run"
    before = _earlier_run(folder)
    limit = 2_000_000  # [bytes]; case 1 for 2 s at dt 1e-4 records ~20,000 rows of ~1 kB

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    done = _cli("--case", "1", "--duration", "2", "--dt", "1e-4", "--no-html", "--out",
                str(folder), preexec_fn=small_files)  # fmt: skip
    lines = _error_lines(done.stderr)
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and lines[0].startswith("error:") and "ulimit -f" in lines[0]
    assert "--record-every" in lines[0]
    _unchanged(folder, before)


def test_an_unwritable_folder_is_refused_before_the_run(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        done = _cli("--case", "1", "--duration", "0.05", "--out", str(folder))
    finally:
        folder.chmod(0o700)
    assert done.returncode == 4 and _error_lines(done.stderr)[0].startswith("error: cannot write")


def test_run_folder_commits_summary_last_and_cleans_dead_staging(tmp_path):
    """Unit: an abandoned RunFolder leaves nothing; a staging folder of a dead process is
    removed by the next one; the commit renames summary.json last."""
    (tmp_path / f"{files_module.STAGING_PREFIX}999999999-x").mkdir()
    with RunFolder(tmp_path) as out:
        out.path("summary.json").write_text("{}")
        out.path("trajectory.npz").write_bytes(b"npz")
        assert not (tmp_path / f"{files_module.STAGING_PREFIX}999999999-x").exists()
        order = []
        real = os.replace
        files_module.os.replace = lambda a, b: (order.append(Path(b).name), real(a, b))[1]
        try:
            out.commit()
        finally:
            files_module.os.replace = real
    assert order == ["trajectory.npz", "summary.json"]
    with RunFolder(tmp_path / "b") as out:
        out.path("summary.json").write_text("{}")  # no commit: abandoned
    assert list((tmp_path / "b").iterdir()) == []


def _wait_for(predicate, timeout: float = 120.0, every: float = 0.005) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > end:
            raise AssertionError("timed out")
        time.sleep(every)


def _staging(folder: Path) -> bool:
    return any(p.is_dir() for p in folder.glob(".ffsm-staging-*"))


# The write made to last: the presses must land inside it however fast the machine writes
# (on a fast one the whole write took under the 50 ms between two presses, and the second press
# then killed an interpreter that had already returned 130).
SLOW_WRITE = """
import sys, time
from ffsm_pin.sim import files
commit = files.RunFolder.commit
def slow_commit(self):
    time.sleep(3.0)
    commit(self)
files.RunFolder.commit = slow_commit
from ffsm_pin.sim.cli import main
raise SystemExit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("presses", [1, 2])
def test_ctrl_c_while_the_files_are_written(tmp_path, presses):
    """SIGINT timed into the final write. Once: the write completes (every contract key,
    a summary), exit 130. Twice: the write is abandoned and the earlier run is intact."""
    folder = tmp_path / "run"
    before = _earlier_run(folder)
    err_file = tmp_path / "stderr.txt"
    with err_file.open("w") as err_out:
        proc = subprocess.Popen(
            [sys.executable, "-c", SLOW_WRITE, "--case", "1", "--duration", "3", "--dt", "1e-4",
             "--no-html", "--out", str(folder)],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=err_out, text=True,
        )  # fmt: skip
        _wait_for(lambda: _staging(folder) or proc.poll() is not None)
        proc.send_signal(signal.SIGINT)
        if presses == 2:  # the second once the first was seen (two could merge into one)
            _wait_for(lambda: "Ctrl-C again" in err_file.read_text() or proc.poll() is not None)
            proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=300)
    err = err_file.read_text()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    if presses == 2:
        _unchanged(folder, before)
        return
    with np.load(folder / "trajectory.npz") as npz:
        assert set(CONTRACT_KEYS) <= set(npz.files)
        assert npz["t"][-1] == pytest.approx(3.0)
    assert json.loads((folder / "summary.json").read_text())["duration"] == 3.0


# --------------------------------------------------------------------- spool and --recover
RUNNER = """
import sys
import ffsm_pin.sim.recorder as recorder
recorder.CHUNK_BYTES = 2**16  # spill early: a spool within a second of simulated time
from ffsm_pin.sim.cli import main
raise SystemExit(main(sys.argv[1:]))
"""


def _spool_rows(folder: Path) -> int:
    for spool in folder.glob(".ffsm-spool-*"):
        t = spool / "t.bin"
        if t.is_file() and t.stat().st_size > 8 * 200:
            return t.stat().st_size // 8
    return 0


def test_kill_9_then_recover(tmp_path):
    """A run killed mid-way leaves a self-describing spool in its folder; --recover turns it
    into trajectory.npz and summary.json (completed false, recovered) whose rows are those of
    a complete run of the same scenario, bit for bit, and removes the spool."""
    folder = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-c", RUNNER, "--case", "1", "--duration", "30", "--no-plots",
         "--no-html", "--quiet", "--out", str(folder)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    _wait_for(lambda: _spool_rows(folder) > 0 or proc.poll() is not None)
    proc.kill()
    proc.wait()
    (spool,) = folder.glob(".ffsm-spool-*")
    header = json.loads((spool / "spool.json").read_text())
    assert header["format"] == "ffsm-pin spool 1" and 'name = "case1"' in header["scenario_toml"]
    assert not (folder / "trajectory.npz").exists()

    done = _cli("--recover", str(folder), "--no-plots", "--no-html")
    assert done.returncode == 3, done.stderr
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["completed"] is False and summary["stop_cause"] == "recovered"
    assert summary["blas"] == header["blas"] and summary["versions"] == header["versions"]
    assert "recovered" in summary["stop_reason"]
    assert not list(folder.glob(".ffsm-spool-*"))  # the spool is gone once written
    with np.load(folder / "trajectory.npz") as npz:
        assert set(CONTRACT_KEYS) <= set(npz.files)
        rows = len(npz["t"])
        recovered = {k: npz[k] for k in ("t", "q", "v", "u_m", "theta_d_hat", "err_z", "P")}
    assert rows > 0 and summary["stop_time"] == pytest.approx(recovered["t"][-1])
    full = simulate(prepare(_short_case1(recovered["t"][-1])))
    for key, value in recovered.items():
        assert np.array_equal(np.asarray(full[key])[:rows], value), key


def _short_case1(duration: float):
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario

    return dataclasses.replace(builtin_scenario("case1"), duration=float(duration))


def test_recover_without_a_spool_is_one_error_line(tmp_path):
    done = _cli("--recover", str(tmp_path))
    lines = _error_lines(done.stderr)
    assert done.returncode == 2 and len(lines) == 1 and "no spool" in lines[0]


# --------------------------------------------------------------------- controllers and truth
MUTATES = (
    PD
    + """
    def step(self, meas):
        u = self.torque(meas)
        meas.q_m[:] = 99.0
        meas.w[:] = 99.0
        meas.z_e[:] = 99.0
        meas.z_e_dot[:] = 99.0
        return u
"""
)
HONEST = PD + "\n    def step(self, meas):\n        return self.torque(meas)\n"


@pytest.mark.parametrize("sensors", [False, True])
def test_a_controller_writing_into_its_measurement_changes_no_record(tmp_path, sensors):
    """The recorded truth (and what the controller saw, with sensors) is what was measured,
    whatever the controller writes into its measurement afterwards."""
    import dataclasses

    from ffsm_pin.scenario import SensorSpec

    runs = {}
    for name, body in (("mutates", MUTATES), ("honest", HONEST)):
        sc = _short(_controller_scenario(tmp_path, body, name), 0.2)
        if sensors:
            spec = SensorSpec(seed=1, delay=2, noise=(("joints", 1e-4),))
            sc = dataclasses.replace(sc, sensors=spec)
        runs[name] = simulate(prepare(sc))
    a, b = runs["mutates"], runs["honest"]
    assert a.completed and b.completed
    keys = ["q", "v", "w", "z_e", "z_e_dot", "q_b", "err_z", "u_m"]
    keys += ["meas_q_m", "meas_w", "meas_z_e"] if sensors else []
    for key in keys:
        assert np.array_equal(a[key], b[key]), key
    assert a.summary()["funnel_ok_z"] == b.summary()["funnel_ok_z"]


EXITS_IN_STEP = PD + "\n    def step(self, meas):\n        import sys\n        sys.exit(0)\n"
EXITS_LATER = (
    PD
    + """
    def step(self, meas):
        if meas.t > 0.1:
            raise SystemExit("bye")
        return self.torque(meas)
"""
)


def test_sys_exit_in_step_stops_the_run_with_everything_written(tmp_path):
    path = _controller_scenario(tmp_path, EXITS_LATER)
    out = tmp_path / "out"
    done = _cli("--scenario", str(path), "--duration", "0.3", "--no-plots", "--no-html",
                "--out", str(out))  # fmt: skip
    assert done.returncode == 3, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["completed"] is False and summary["stop_cause"] == "controller"
    assert "SystemExit" in summary["stop_reason"]
    with np.load(out / "trajectory.npz") as npz:
        assert npz["t"][-1] == pytest.approx(0.1, abs=1.5e-3)


def test_sys_exit_at_import_is_bad_input(tmp_path):
    path = _controller_scenario(tmp_path, "import sys\nsys.exit(0)\n" + HONEST)
    done = _cli("--scenario", str(path), "--duration", "0.05", "--out", str(tmp_path / "o"))
    lines = _error_lines(done.stderr)
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert lines[0].startswith("error:") and "SystemExit" in lines[0]
    assert not (tmp_path / "o" / "summary.json").exists()


@pytest.mark.parametrize("torque", ["[True] * 4", "[1 + 2j] * 4", "['1.0'] * 4"])
def test_torques_must_be_real_numbers(tmp_path, torque):
    body = PD + f"\n    def step(self, meas):\n        return {torque}\n"
    res = simulate(prepare(_short(_controller_scenario(tmp_path, body), 0.05)))
    assert not res.completed and res.stop_cause == "controller"
    assert "expected real numbers" in res.stop_reason


SIGNAL_TURNS = (
    PD
    + """
    def step(self, meas):
        s = {"a": 1.0} if meas.t < 0.05 else {"a": {"not": "a number"}}
        return self.torque(meas), s
"""
)
STANDARD_WRONG_SHAPE = (
    PD
    + "\n    def step(self, meas):\n        return self.torque(meas), {'sigma_min': [1.0, 2.0]}\n"
)


def test_a_signal_turning_into_a_dict_stops_the_run_cleanly(tmp_path):
    out = tmp_path / "out"
    path = _controller_scenario(tmp_path, SIGNAL_TURNS)
    done = _cli("--scenario", str(path), "--duration", "0.2", "--no-plots", "--no-html",
                "--out", str(out))  # fmt: skip
    assert done.returncode == 3 and "Traceback" not in done.stderr, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stop_cause"] == "controller" and "'a'" in summary["stop_reason"]
    with np.load(out / "trajectory.npz") as npz:
        assert len(npz["t"]) > 40 and npz["t"][-1] < 0.05 + 1e-9  # the rows before it
        assert np.all(npz["ctrl_a"] == 1.0)


def test_a_standard_signal_of_the_wrong_shape_stops_at_the_first_period(tmp_path):
    res = simulate(prepare(_short(_controller_scenario(tmp_path, STANDARD_WRONG_SHAPE), 0.05)))
    assert not res.completed and res.stop_cause == "controller"
    assert "sigma_min" in res.stop_reason
    summary = res.summary()  # no traceback in the summary of a run without rows
    assert summary["funnel_ok_b"] is False and summary["funnel_ok_z"] is False


# --------------------------------------------------------------------- strict JSON
def test_summary_json_is_strict_after_a_blow_up(tmp_path):
    """Torques that blow the plant up: summary.json parses without NaN or Infinity."""
    body = PD + "\n    def step(self, meas):\n        return [1e200, -1e200, 1e200, -1e200]\n"
    out = tmp_path / "out"
    path = _controller_scenario(tmp_path, body)
    done = _cli("--scenario", str(path), "--duration", "0.05", "--no-plots", "--no-html",
                "--out", str(out))  # fmt: skip
    assert done.returncode == 3, done.stderr

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    summary = json.loads((out / "summary.json").read_text(), parse_constant=refuse)
    assert summary["completed"] is False and summary["stop_cause"] == "nonfinite"


def test_strict_json_turns_non_finite_numbers_into_null():
    text = strict_json({"a": float("inf"), "b": [1.0, float("nan")], "c": {"d": -float("inf")}})
    assert json.loads(text) == {"a": None, "b": [1.0, None], "c": {"d": None}}


SHADOWS = (
    PD
    + """
    def step(self, meas):
        bogus = {"t": -1.0, "q": [9.0] * 8, "err_z": [9.0] * 3, "ctrl_t": 5.0, "u_m": [7.0] * 4}
        return self.torque(meas), bogus
"""
)


def test_a_controller_cannot_shadow_the_standard_outputs(tmp_path):
    """Signals named like the run's own outputs are saved under ctrl_ names; the outputs keep
    the run's values (compared with the same law reporting nothing)."""
    shadow = simulate(prepare(_short(_controller_scenario(tmp_path, SHADOWS, "shadow"), 0.05)))
    honest = simulate(prepare(_short(_controller_scenario(tmp_path, HONEST, "honest"), 0.05)))
    for key in ("t", "q", "err_z", "u_m"):
        assert np.array_equal(shadow[key], honest[key]), key
    assert np.all(shadow["ctrl_t"] == -1.0) and np.all(shadow["ctrl_ctrl_t"] == 5.0)
    assert np.all(shadow["ctrl_u_m"] == 7.0)
