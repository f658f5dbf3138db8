"""One URDF writer for both geometries (ffsm_pin.robot.writer): the table's geometry is told
apart by ``kind`` or the base inertia, and ambiguous or unknown kinds are refused naming the
choices."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ffsm_pin.errors import ParameterError
from ffsm_pin.robot import writer
from ffsm_pin.robot.writer import PlanarChain, SpatialChain, read_table

REPO = Path(__file__).resolve().parents[2]
PLANAR = REPO / "urdf" / "ffsm_planar4.toml"
SPATIAL = REPO / "tests" / "data" / "spatial3.toml"


def _cli(module: str, *args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *map(str, args)],
        cwd=REPO, capture_output=True, text=True, check=False,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("path", "kind", "cls"),
    [(PLANAR, "planar", PlanarChain), (SPATIAL, "spatial", SpatialChain)],
    ids=["planar", "spatial"],
)
def test_the_geometry_is_read_off_the_table(path, kind, cls):
    table = read_table(path)
    assert writer.table_kind(table) == kind
    chain = writer.chain_from_table(table)
    assert isinstance(chain, cls)
    assert writer.chain_from_table({**table, "kind": kind}) == chain  # said explicitly


def test_an_explicit_kind_wins_over_the_inertia():
    table = read_table(PLANAR)
    with pytest.raises(ParameterError, match="base.inertia"):  # a number is no 6-vector
        writer.chain_from_table({**table, "kind": "spatial"})


@pytest.mark.parametrize(
    ("table", "match"),
    [
        (
            {"kind": "cartesian", "base": {}},
            r"kind 'cartesian' unknown; valid choices: "
            r"'planar', 'spatial'",
        ),  # fmt: skip
        ({"base": {"mass": 1.0}}, "cannot tell planar from spatial: set kind"),
        ({"links": []}, "cannot tell planar from spatial"),
    ],
)
def test_unknown_or_ambiguous_kind_is_refused_with_the_choices(table, match):
    with pytest.raises(ParameterError, match=match):
        writer.chain_from_table(table)


def test_command_line_ambiguous_table_is_one_error_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[base]\nmass = 1.0\n")
    proc = _cli("ffsm_pin.robot.writer", bad)
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1
    assert "kind" in proc.stderr


@pytest.mark.parametrize("path", [PLANAR, SPATIAL], ids=["planar", "spatial"])
def test_command_line_writes_either_geometry(path):
    """One command for both geometries (it replaced ``python -m ffsm_pin.planar_urdf`` and
    ``python -m ffsm_pin.spatial_urdf``, removed in 0.2.0)."""
    proc = _cli("ffsm_pin.robot.writer", path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert proc.stdout == writer.chain_to_urdf(writer.chain_from_table(read_table(path)))
