"""The planar URDF writer (ffsm_pin.robot.writer.planar): tables round-trip through the
loader, the command line reproduces the committed URDFs byte for byte, bad tables are refused
naming the key."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.errors import ParameterError
from ffsm_pin.robot import load_robot
from ffsm_pin.robot.writer import PlanarLink, chain_to_urdf, write_urdf
from ffsm_pin.robot.writer.planar import chain_from_table

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
TABLES = [
    REPO / "urdf" / "ffsm_planar4.toml",
    REPO / "tests" / "data" / "planar5_collinear.toml",
    REPO / "tests" / "data" / "planar5_offaxis.toml",
]
# geometry passes through Pinocchio's SE3/inertia algebra: a few ulps
ATOL = 1e-14


def expected_geometry(table: dict) -> dict:
    """What the table means, read directly (defaults as documented in
    ffsm_pin/robot/writer/planar.py)."""
    base, links = table["base"], table["links"]
    tips = [lk.get("tip", [lk["length"], 0.0]) for lk in links]
    return {
        "name": table.get("name", "planar_ffsm"),
        "end_effector": table.get("end_effector", "ee"),
        "masses": [base["mass"]] + [lk["mass"] for lk in links],
        "inertias": [base["inertia"]] + [lk["inertia"] for lk in links],
        "coms": [base.get("com", [0.0, 0.0])]
        + [lk.get("com", [lk["length"] / 2, 0.0]) for lk in links],
        "child_joints": [base["mount"]] + tips[:-1],
        "ee_position": tips[-1],
        "axis_signs": [lk.get("axis", 1) for lk in links],
    }


def check_geometry(robot, expected):
    g = robot.geometry
    assert robot.name == expected["name"]
    assert robot.ee_frame == expected["end_effector"]
    np.testing.assert_array_equal(g.masses, expected["masses"])
    np.testing.assert_array_equal(g.inertias, expected["inertias"])
    np.testing.assert_allclose(g.coms, expected["coms"], rtol=0, atol=ATOL)
    np.testing.assert_allclose(g.child_joints, expected["child_joints"], rtol=0, atol=ATOL)
    np.testing.assert_allclose(g.ee_position, expected["ee_position"], rtol=0, atol=ATOL)
    np.testing.assert_array_equal(g.axis_signs, expected["axis_signs"])
    np.testing.assert_array_equal(g.joint_yaws, np.zeros(len(expected["axis_signs"])))
    assert g.ee_body == len(expected["axis_signs"]) and g.ee_yaw == 0.0


@pytest.mark.parametrize("table_path", TABLES, ids=[p.stem for p in TABLES])
def test_table_round_trips_through_loader(table_path, tmp_path):
    table = tomllib.loads(table_path.read_text())
    chain = chain_from_table(table)
    path = tmp_path / "robot.urdf"
    path.write_text(chain_to_urdf(chain))
    robot = load_robot(path, end_effector=chain.end_effector)
    check_geometry(robot, expected_geometry(table))


@pytest.mark.parametrize("offaxis", [False, True])
@pytest.mark.parametrize("seed", [0, 1])
def test_random_chains_round_trip(random_chain, make_chain, offaxis, seed):
    chain = random_chain(6, offaxis=offaxis, seed=seed)
    robot = make_chain(6, offaxis=offaxis, seed=seed)
    tips = [lk.tip for lk in chain.links]
    check_geometry(
        robot,
        {
            "name": chain.name,
            "end_effector": chain.end_effector,
            "masses": [chain.base.mass] + [lk.mass for lk in chain.links],
            "inertias": [chain.base.inertia] + [lk.inertia for lk in chain.links],
            "coms": [chain.base.com] + [lk.com for lk in chain.links],
            "child_joints": [chain.mount] + tips[:-1],
            "ee_position": tips[-1],
            "axis_signs": [lk.axis for lk in chain.links],
        },
    )


def _cli(*args, cwd=REPO):
    return subprocess.run(
        [sys.executable, "-m", "ffsm_pin.robot.writer", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        check=False,
    )


def test_cli_reproduces_shipped_urdf_byte_for_byte():
    result = _cli("urdf/ffsm_planar4.toml")
    assert result.returncode == 0, result.stderr
    assert result.stdout == (REPO / "urdf" / "ffsm_planar4.urdf").read_bytes()


@pytest.mark.parametrize("table_path", TABLES, ids=[p.stem for p in TABLES])
def test_cli_output_file_matches_committed_urdf(table_path, tmp_path):
    out = tmp_path / "out.urdf"
    result = _cli(table_path, "-o", out)
    assert result.returncode == 0, result.stderr
    assert result.stdout == b""
    assert out.read_bytes() == table_path.with_suffix(".urdf").read_bytes()


def test_write_urdf_returns_path(random_chain, tmp_path):
    chain = random_chain(4)
    path = write_urdf(chain, str(tmp_path / "w.urdf"))
    assert path == tmp_path / "w.urdf"
    assert path.read_text() == chain_to_urdf(chain)


# ----------------------------------------------------------------------------- bad tables
def _table(**changes) -> dict:
    table = {
        "name": "t",
        "base": {"mass": 50.0, "inertia": 20.0, "mount": [0.8, 0.0]},
        "links": [
            {"mass": 5.0, "inertia": 0.8, "length": 1.2},
            {"mass": 4.0, "inertia": 0.6, "length": 1.1},
        ],
    }
    for key, value in changes.items():  # "key" (top level), "base__key", "link<i>__key"
        section, _, field = key.partition("__")
        if not field:
            target, field = table, section
        elif section == "base":
            target = table["base"]
        else:
            target = table["links"][int(section.removeprefix("link"))]
        if value is None:
            del target[field]
        else:
            target[field] = value
    return table


BAD_TABLES = [
    ({"base__mass": None}, r"'mass'"),
    ({"base__inertia": None}, r"'inertia'"),
    ({"base__mount": None}, r"'mount'"),
    ({"base": None}, r"'base'"),
    ({"links": None}, r"'links'"),
    ({"link1__length": None}, r"'length'"),
    ({"link0__mass": None}, r"'mass'"),
    ({"links": []}, r"link"),
    ({"base__mass": -50.0}, r"base: mass"),
    ({"base__inertia": 0.0}, r"base: inertia"),
    ({"link1__mass": 0.0}, r"link 2: mass"),
    ({"link0__inertia": -1.0}, r"link 1: inertia"),
    ({"link1__axis": 2}, r"links\[2\]\.axis"),
    ({"link0__axis": 0}, r"links\[1\]\.axis"),
]


@pytest.mark.parametrize(("changes", "needle"), BAD_TABLES, ids=[str(c) for c, _ in BAD_TABLES])
def test_bad_table_raises_parameter_error_naming_key(changes, needle):
    with pytest.raises(ParameterError, match=needle):
        chain_from_table(_table(**changes))


def test_good_table_helper_is_valid():
    chain = chain_from_table(_table())  # the base of BAD_TABLES is itself fine
    assert len(chain.links) == 2
    assert chain.links[0].com == (0.6, 0.0) and chain.links[0].tip == (1.2, 0.0)


def test_cli_bad_table_is_one_clear_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[base]\ninertia = 20.0\nmount = [0.8, 0.0]\n[[links]]\nmass = 5.0\n")
    result = _cli(bad)
    assert result.returncode == 2
    err = result.stderr.decode()
    assert "Traceback" not in err
    assert err.count("\n") == 1 and "bad.toml" in err and "'mass'" in err
    assert result.stdout == b""


def test_cli_malformed_toml(tmp_path):
    bad = tmp_path / "broken.toml"
    bad.write_text("[base\nmass = 1\n")
    result = _cli(bad)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr.decode()
    assert "broken.toml" in result.stderr.decode()


def test_non_numeric_value_is_parameter_error():
    with pytest.raises(ParameterError, match=r"base\.mass"):
        chain_from_table(_table(base__mass="heavy"))


def test_wrong_vector_length_names_the_key():
    with pytest.raises(ParameterError, match="mount"):
        chain_from_table(_table(base__mount=[0.8, 0.0, 0.0]))


def test_fractional_axis_is_refused():
    with pytest.raises(ParameterError, match="axis"):
        PlanarLink(mass=1.0, inertia=1.0, axis=1.5)


def test_names_are_escaped_in_attributes(random_chain, tmp_path):
    chain = dataclasses.replace(random_chain(4), name='arm "A" & <b>', end_effector='tool"1')
    robot = load_robot(write_urdf(chain, tmp_path / "q.urdf"), end_effector='tool"1')
    assert robot.name == 'arm "A" & <b>'
