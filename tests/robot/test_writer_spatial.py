"""The spatial URDF writer (ffsm_pin.robot.writer.spatial): the command line writes what the
Python API writes, and bad tables are refused naming the key (the loaded geometry of a
generated URDF is checked in tests/robot/test_robot_spatial.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ffsm_pin.errors import ParameterError
from ffsm_pin.robot.writer import chain_to_urdf, read_table
from ffsm_pin.robot.writer.spatial import chain_from_table

REPO = Path(__file__).resolve().parents[2]
TABLE = REPO / "tests" / "data" / "spatial3.toml"


def test_command_line_writes_the_api_text(tmp_path):
    out = tmp_path / "spatial3.urdf"
    subprocess.run(
        [sys.executable, "-m", "ffsm_pin.robot.writer", str(TABLE), "-o", str(out)],
        check=True,
        cwd=REPO,
    )
    assert out.read_text() == chain_to_urdf(chain_from_table(read_table(TABLE)))


def test_command_line_bad_table_is_one_error_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[base]\nmass = 1.0\ninertia = [1, 0, 0, 1, 0]\n[[links]]\nmass = 1.0\n")
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.robot.writer", str(bad)],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1
    assert "base.inertia" in proc.stderr


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: t["links"][0].pop("origin_xyz"), r"links\[1\]: missing key 'origin_xyz'"),
        (lambda t: t["links"][1].update(axis=[0, 0, 0]), "axis"),
        (lambda t: t["links"][2].update(mass=-1.0), r"links\[3\]: mass must be > 0"),
        (lambda t: t["base"].update(com=[0, 0]), "base.com"),
        (lambda t: t.pop("links"), "missing key 'links'"),
    ],
)
def test_bad_tables_name_the_key(edit, match):
    table = read_table(TABLE)
    edit(table)
    with pytest.raises(ParameterError, match=match):
        chain_from_table(table)
