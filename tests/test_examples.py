"""Every example runs (scripts with short durations, notebooks executed with nbclient), as a
new user would run them from the repository root (README, "Documentation")."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SCRIPTS = {  # file -> arguments that keep it short
    "case1.py": ["--duration", "1"],
    "own_arm.py": ["--duration", "1"],
    "small_campaign.py": ["--duration", "0.3"],
}
SCENARIOS = {"point_to_point.toml": ["--duration", "9"]}  # scenario file -> sim arguments


def test_every_example_is_exercised():
    """A new example must get a line here (or run through a test of its own)."""
    # run by tests/sim/test_user_controller.py
    own_tests = {"joint_pd.py", "joint_pd_planar.toml", "joint_pd_spatial.toml"}
    notebooks = {p.name for p in EXAMPLES.glob("*.ipynb")}
    files = {p.name for p in EXAMPLES.iterdir() if p.is_file()}
    assert files == set(SCRIPTS) | set(SCENARIOS) | own_tests | notebooks


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenario_example_runs(name, tmp_path):
    """The scenario runs through the command line and keeps its funnels."""
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(EXAMPLES / name),
           "--out", str(tmp_path / "out"), "--no-plots", "--no-html", *SCENARIOS[name]]  # fmt: skip
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["funnel_ok_b"] and summary["funnel_ok_z"]


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_script_runs(name, tmp_path):
    args = SCRIPTS[name]
    if name in ("case1.py", "small_campaign.py"):
        args = [*args, "--out", str(tmp_path / "out")]
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), *args], cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip()


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.ipynb")))
def test_notebook_runs(name):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(EXAMPLES / name, as_version=4)
    nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(EXAMPLES)}}).execute()  # fmt: skip
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs
              if o.output_type == "error"]  # fmt: skip
    assert not errors
