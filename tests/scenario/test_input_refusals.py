"""Inputs a hostile but realistic user tries (issue 37): each is refused by the command line with
exit status 2 and one ``error:`` line that names the offending key, joint or file, leaks none of
a file's content and no text of the C++ libraries underneath (subprocess, as a user runs it)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from ffsm_pin.robot import urdf_dir
from ffsm_pin.scenario.file import builtin_path
from ffsm_pin.sim import compile_note

DATA = Path(__file__).resolve().parents[1] / "data"
CASE1_TEXT = builtin_path("case1").read_text()
# a scenario of the default robot without its reference (the tests add [reference])
MINIMAL = """
[initial]
base_pose = [0.0, 0.0, 0.0]
joints = [0.5, 0.5, 0.5, 0.5]
base_twist = [0.0, 0.0, 0.0]
"""
RUN = ("--duration", "0.01", "--no-plots", "--no-html", "--out", "o")


def sim(*args: str, cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", *args],
        cwd=cwd,
        capture_output=True,
        timeout=600,
        env=env,
    )
    proc.stdout, proc.stderr = proc.stdout.decode(errors="replace"), proc.stderr.decode()
    return proc


def error_line(proc: subprocess.CompletedProcess, *, warnings_allowed: bool = True) -> str:
    """The one ``error:`` line of a refused run (exit 2, no traceback, nothing else on stderr
    but ``warning:`` lines and, on a cold numba cache, the compile note)."""
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    lines = [s for s in proc.stderr.splitlines() if s.strip() and s != compile_note.MESSAGE]
    errors = [s for s in lines if s.startswith("error: ")]
    others = [s for s in lines if not s.startswith("error: ")]
    assert len(errors) == 1, lines
    if warnings_allowed:
        assert all(s.startswith("warning: ") for s in others), lines
    else:
        assert others == [], lines
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    return errors[0]


def case1_with(tmp_path: Path, extra: str = "", **lines: str) -> Path:
    """case1.toml with whole ``key = ...`` lines replaced and ``extra`` appended."""
    text = CASE1_TEXT
    for key, line in lines.items():
        text, n = re.subn(rf"(?m)^{re.escape(key)} = .*$", line, text)
        assert n == 1, key
    path = tmp_path / "s.toml"
    path.write_text(text + "\n" + extra)
    return path


def with_reference(tmp_path: Path, reference: str) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(MINIMAL + "\n[reference]\n" + reference + "\n")
    return path


# ------------------------------------------------------------------------ 1: torque limits
def sloppy_planar4(tmp_path: Path) -> Path:
    """The paper's robot with joint4's <limit> removed (the loader repairs it)."""
    urdf = (urdf_dir() / "ffsm_planar4.urdf").read_text()
    joint4 = urdf.index('<joint name="joint4"')
    limit = urdf.index("<limit", joint4)
    urdf = urdf[:limit] + urdf[urdf.index("/>", limit) + 2 :]
    path = tmp_path / "sloppy.urdf"
    path.write_text(urdf)
    return path


def test_urdf_torque_limit_without_effort_in_the_file_is_refused(tmp_path):
    urdf = sloppy_planar4(tmp_path)
    path = case1_with(
        tmp_path, "[actuators]\ntorque_limit = 'urdf'\n", urdf=f'urdf = "{urdf.name}"'
    )
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "actuators.torque_limit" in line and "'joint4'" in line, line
    assert "joint1" not in line  # the joints with a limit are not blamed
    assert "torque_limit = 50.0" in line  # what to give instead


def test_repair_warning_does_not_promise_a_limit(tmp_path):
    """The repair's warning says the joint has no torque limit, not the invented effort."""
    urdf = sloppy_planar4(tmp_path)
    path = case1_with(tmp_path, urdf=f'urdf = "{urdf.name}"')
    proc = sim("--scenario", str(path), *RUN, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    warned = [s for s in proc.stderr.splitlines() if "joint4" in s]
    assert len(warned) == 1 and warned[0].startswith("warning: "), proc.stderr
    assert "no torque limit" in warned[0] and "1e3" not in warned[0] and "1000" not in warned[0]


# ------------------------------------------------------------------------ 2: sensor delay
def test_sensor_delay_longer_than_the_run_is_refused(tmp_path):
    path = case1_with(tmp_path, "[sensors]\ndelay = 500\n")
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "sensors.delay = 500" in line and "sim.duration = 0.01" in line, line


def test_sensor_delay_shorter_than_the_run_is_accepted(tmp_path):
    path = case1_with(tmp_path, "[sensors]\ndelay = 3\n")
    proc = sim("--scenario", str(path), *RUN, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr


# ------------------------------------------------------------------------ 3: data files
@pytest.mark.skipif(not Path("/etc/passwd").is_file(), reason="no /etc/passwd")
def test_reference_file_that_is_no_csv_is_not_echoed(tmp_path):
    path = with_reference(tmp_path, 'ee_file = "/etc/passwd"')
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "/etc/passwd" in line and "line 1" in line, line
    content = [s for s in Path("/etc/passwd").read_text().splitlines() if s.strip()]
    assert "root:" not in line and not any(s in line for s in content[:3]), line


@pytest.mark.skipif(not Path("/proc/self/environ").is_file(), reason="no /proc/self/environ")
def test_process_environment_as_reference_file_is_not_echoed(tmp_path):
    secret = "hunter2-do-not-print"
    path = with_reference(tmp_path, 'ee_file = "/proc/self/environ"')
    env = {**os.environ, "FFSM_TEST_SECRET": secret}
    proc = sim("--scenario", str(path), *RUN, cwd=tmp_path, env=env)
    line = error_line(proc)
    assert "/proc/self/environ" in line, line
    assert secret not in proc.stderr and "FFSM_TEST_SECRET" not in proc.stderr


def test_bad_cell_is_named_by_line_not_quoted(tmp_path):
    (tmp_path / "r.csv").write_text("t, x, y, a\n0, 1, 2, 3\n1, 1, s3cr3t, 3\n")
    path = with_reference(tmp_path, 'ee_file = "r.csv"')
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "r.csv" in line and "line 3" in line and "number" in line, line
    assert "s3cr3t" not in line


# ------------------------------------------------------------------------ 4: not a file
def test_folder_as_reference_file(tmp_path):
    (tmp_path / "samples").mkdir()
    path = with_reference(tmp_path, 'ee_file = "samples"')
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "samples" in line and "is a folder, not a file" in line, line


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_as_reference_file(tmp_path):
    os.mkfifo(tmp_path / "pipe")
    path = with_reference(tmp_path, 'ee_file = "pipe"')
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "pipe" in line and "is not a regular file" in line, line


# ------------------------------------------------------------------------ 5: lengths
def test_one_component_length_is_not_offered_twice(tmp_path):
    """A planar base attitude has 1 component: 'expected 1', never 'expected 1 or 1'."""
    path = case1_with(tmp_path, "[sensors.noise]\nbase_attitude = [0.1, 0.2]\n")
    line = error_line(sim("--scenario", str(path), *RUN, cwd=tmp_path))
    assert "sensors.noise.base_attitude" in line, line
    assert re.search(r"expected 1\b", line) and "1 or 1" not in line, line


# ------------------------------------------------------------------------ 6: step count
@pytest.mark.parametrize("duration", ["1e308", "1e20"])
def test_absurd_step_count_is_refused(tmp_path, duration):
    args = ("--case", "case1", "--duration", duration, "--no-plots", "--no-html", "--out", "o")
    line = error_line(sim(*args, cwd=tmp_path))
    assert "sim.duration" in line and "sim.dt" in line and "steps" in line, line


# ------------------------------------------------------------------------ 7: C++ output
@pytest.mark.parametrize(
    ("urdf", "named"),
    [("bad_malformed.urdf", "well-formed"), ("bad_mass_text.urdf", "mass")],
)
def test_urdf_parser_output_is_folded_into_the_error_line(tmp_path, urdf, named):
    path = case1_with(tmp_path, urdf=f'urdf = "{DATA / urdf}"')
    proc = sim("--scenario", str(path), *RUN, cwd=tmp_path)
    line = error_line(proc, warnings_allowed=False)
    assert urdf in line and named in line, line
    assert "link.cpp" not in proc.stderr and "urdfdom/urdf_parser" not in proc.stderr
