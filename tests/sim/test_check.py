"""``--check``: a dry run that exits 0 on the shipped scenarios and 2 on doomed ones."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

from ffsm_pin.sim.cli import main

SCEN = Path(str(resources.files("ffsm_pin.sim") / "scenarios"))


def _doomed(tmp_path: Path, old: str, new: str) -> Path:
    text = (SCEN / "case1.toml").read_text()
    for o, n in zip(old.split("|"), new.split("|"), strict=True):
        assert o in text  # the substitution must bite
        text = text.replace(o, n, 1)
    path = tmp_path / "doomed.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", ["case1", "case1-paper", "case3", "planar5"])
def test_builtin_passes(case, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["--check", "--case", case]) == 0
    assert "sigma_min(0)" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []  # no run folder written


@pytest.mark.parametrize(
    ("old", "new", "reason"),
    [
        ("c = 3.9,", "c = 5.9,", "not strictly inside its funnel"),
        # far away, with a funnel wide enough to start inside it: only the reach speaks
        (
            "c = 3.9,|rho_z0 = [1.0, 1.0, 0.2]",
            "c = 39.0,|rho_z0 = [100.0, 100.0, 0.2]",
            "reach",
        ),
        (
            "joints = [1.0471975511965976, -1.0471975511965976, 1.0471975511965976, "
            "-1.0471975511965976]|rho_z0 = [1.0, 1.0, 0.2]",
            "joints = [0.0, 0.0, 0.0, 0.0]|rho_z0 = [100.0, 100.0, 0.2]",
            "singular",
        ),
        ("k_b = 0.04", "k_bb = 0.04", "k_bb"),
    ],
)
def test_doomed_exits_2(old, new, reason, tmp_path, capsys, monkeypatch):
    path = _doomed(tmp_path, old, new)
    monkeypatch.chdir(tmp_path)
    assert main(["--check", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert lines and any(reason in ln for ln in lines), err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["doomed.toml"]  # no run folder


def test_funnel_error_names_both_fixes(tmp_path, capsys):
    path = _doomed(
        tmp_path, "rho_z0 = [1.0, 1.0, 0.2]|c = 3.9,", "rho_z0 = [1.0, 1.0, 0.2]|c = 5.9,"
    )
    assert main(["--check", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert "increase controller.funnel.rho_z0" in err
    assert "move reference.ee" in err and "z_e(0) = [" in err


def test_short_joints_blames_joints(tmp_path, capsys):
    path = _doomed(
        tmp_path,
        "joints = [1.0471975511965976, -1.0471975511965976, 1.0471975511965976, "
        "-1.0471975511965976]",
        "joints = [1.0, -1.0, 1.0]",
    )
    assert main(["--check", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert "initial.joints has 3" in err and "has 4 joints" in err
    assert "joint_rates" not in err


def test_short_joint_rates_blames_joint_rates(tmp_path, capsys):
    path = _doomed(tmp_path, "joint_rates = [0.0, 0.0, 0.0, 0.0]", "joint_rates = [0.0, 0.0]")
    assert main(["--check", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert "initial.joint_rates has 2" in err and "has 4 joints" in err
