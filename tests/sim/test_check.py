"""``--check``: a dry run that exits 0 on the shipped scenarios and 2 on doomed ones."""

from __future__ import annotations

import os
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import ffsm_pin
from ffsm_pin.robot import urdf_dir
from ffsm_pin.robot.writer import chain_from_table, write_urdf
from ffsm_pin.scenario.file import BUILTIN
from ffsm_pin.sim.cli import main

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SCEN = Path(str(resources.files("ffsm_pin.scenario") / "builtin"))


def _doomed(tmp_path: Path, old: str, new: str) -> Path:
    text = (SCEN / "case1.toml").read_text()
    for o, n in zip(old.split("|"), new.split("|"), strict=True):
        assert o in text  # the substitution must bite
        text = text.replace(o, n, 1)
    path = tmp_path / "doomed.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", sorted(BUILTIN))
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


def test_too_few_joints_exits_2(tmp_path, capsys):
    """A 3-joint arm cannot serve the planar pose task (3) plus the base attitude (1)."""
    text = (SCEN / "case1.toml").read_text()
    table = tomllib.loads((urdf_dir() / "ffsm_planar4.toml").read_text())
    table["links"] = table["links"][:3]
    write_urdf(chain_from_table(table), tmp_path / "arm3.urdf")
    joints = "joints = [1.0471975511965976, -1.0471975511965976, 1.0471975511965976, "
    joints += "-1.0471975511965976]"
    assert joints in text and 'urdf = "ffsm_planar4.urdf"' in text
    text = text.replace(joints, "joints = [1.0, -1.0, 1.0]")
    text = text.replace("joint_rates = [0.0, 0.0, 0.0, 0.0]", "joint_rates = [0.0, 0.0, 0.0]")
    text = text.replace('urdf = "ffsm_planar4.urdf"', 'urdf = "arm3.urdf"')
    path = tmp_path / "doomed.toml"
    path.write_text(text)
    assert main(["--check", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert "needs at least 4 manipulator joints" in err and "the robot has 3" in err, err
    assert "Traceback" not in err


def test_attitude_beyond_authority_exits_2(tmp_path, capsys):
    """The shipped spatial case on a bus 1000 times stiffer in rotation (same mass, so the
    initial pose and errors are unchanged): the arm can no longer buy the 12 degree
    correction."""
    text = (SCEN / "spatial.toml").read_text()
    old = "inertia = [3.0, 3.24, 3.48, 0.0, 0.0, 0.0]"
    assert old in text
    text = text.replace(old, "inertia = [3000.0, 3240.0, 3480.0, 0.0, 0.0, 0.0]")
    path = tmp_path / "doomed.toml"
    path.write_text(text)
    assert main(["--check", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert any("authority" in ln for ln in err.splitlines() if ln.startswith("error:")), err
    assert main(["--check", "--case", "spatial"]) == 0  # the shipped bus passes


def test_other_warnings_of_the_setup_still_show(monkeypatch):
    """--check turns the gain warnings of the set-up into problems; any other warning the
    set-up raises (a URDF repair, say) is shown as on a run, not swallowed."""
    import warnings

    from ffsm_pin.control.gains import GainWarning
    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim import setup
    from ffsm_pin.sim.check import check

    original = setup.prepare

    def noisy(scenario):
        warnings.warn("a URDF repair", UserWarning, stacklevel=1)
        warnings.warn("k_z breaks a condition", GainWarning, stacklevel=1)
        return original(scenario)

    monkeypatch.setattr(setup, "prepare", noisy)
    with pytest.warns(UserWarning, match="a URDF repair") as shown:
        report = check(builtin_scenario("case1"))
    assert report.problems == ["k_z breaks a condition"]
    assert not [w for w in shown if w.category is GainWarning]


def test_check_names_the_file_a_user_controller_runs(capsys):
    """A .py controller type is code: --check says which file it loads (CONTRACT, Nothing lost)."""
    examples = Path(__file__).resolve().parents[2] / "examples"
    assert main(["--check", "--scenario", str(examples / "joint_pd_planar.toml")]) == 0
    out = capsys.readouterr().out
    assert f"loads and runs {(examples / 'joint_pd.py').resolve()} (class JointPD)" in out
    assert main(["--check", "--case", "1"]) == 0
    assert "loads and runs" not in capsys.readouterr().out  # built-in types run no user file


def _spatial_with_reference_attitude(tmp_path: Path, q_bd: str) -> Path:
    text = (SCEN / "spatial.toml").read_text()
    for old, new in (
        ("base_attitude = [0.0, 0.0, 0.0]", f"base_attitude = {q_bd}"),
        ("rho_b0 = [0.1, 0.1, 0.1]", "rho_b0 = [1.0, 1.0, 1.0]"),
    ):
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "turn.toml"
    path.write_text(text)
    return path


def test_authority_is_judged_along_the_error(tmp_path, capsys):
    """A 90 degree turn of the Panda's bus about z: the arm's largest gain (the old bound,
    sigma_max(H_bb^-1 H_bm) x joint travel) would allow it, but the reactionless motion that
    turns the base about that axis reaches a joint limit first (issue 41)."""
    from ffsm_pin.scenario.file import load_scenario
    from ffsm_pin.sim.check import authority_along, check
    from ffsm_pin.sim.setup import prepare

    path = _spatial_with_reference_attitude(tmp_path, "[0.0, 0.0, 0.4142]")  # tan(90 deg / 4)
    assert main(["--check", "--scenario", str(path)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error:")]
    assert len(err) == 1 and "authority" in err[0] and "limit of joint" in err[0], err
    rep = check(load_scenario(path))
    assert rep.authority is not None and rep.attitude_error is not None
    assert rep.authority < rep.attitude_error
    # the reach is a property of the motion, not of the step it is followed in: steps four
    # times finer (midpoint rule, second order) agree to 5e-3 rad about each axis
    setup = prepare(load_scenario(path))
    for axis in np.eye(3):
        for sign in (1.0, -1.0):
            coarse = authority_along(setup.robot, setup.q0, sign * axis, 2.0)
            fine = authority_along(setup.robot, setup.q0, sign * axis, 2.0, step=0.00125)
            # (where a joint limit and the fold come within a step, either may be named)
            assert coarse.why and fine.why and abs(coarse.angle - fine.angle) < 5e-3


def test_origin_initial_prints_the_resolved_references(capsys):
    assert main(["--check", "--case", "spatial-realistic"]) == 0
    out = capsys.readouterr().out
    assert "reference.origin = 'initial' resolves to base_attitude" in out


@pytest.mark.parametrize("case", ["1", "spatial"])
def test_check_compiles_no_control_kernel(tmp_path, case):
    """``--check`` builds the run but never steps it, so it compiles none of the controller's
    kernels (issue 38): from an empty numba cache, no cache entry of a ``ffsm_pin/control``
    module appears (the sensor's and the model's kernels, which the check evaluates, may)."""
    control = Path(ffsm_pin.__file__).parent / "control"
    stems = {p.stem for p in control.glob("*.py")}
    cache = tmp_path / "numba-cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--case", case, "--check"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    entries = [p.name for p in cache.rglob("*.nbi")]
    compiled_control = sorted(n for n in entries if n.split(".")[0] in stems)
    assert compiled_control == [], compiled_control
    assert "compiling the controller kernels" not in proc.stderr


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_check_warns_when_the_funnels_need_more_torque_than_the_limits(case, tmp_path, capsys):
    """The torque feasibility condition (docs/saturation.md): with limits at half the largest
    need --check warns, naming that joint and the funnel row; at twice it, it does not. Both
    exit 0 (a warning, not a problem), planar and spatial."""
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.check import check
    from ffsm_pin.sim.robots import robot_of

    sc = builtin_scenario(case)
    unlimited = dataclasses.replace(sc.actuators, torque_limit=1e9)
    free = check(dataclasses.replace(sc, actuators=unlimited))
    assert free.torque is not None and free.torque.problem(("j",) * 9) is None
    needed = free.torque.needed
    j = int(np.argmax(needed))
    text = (SCEN / f"{case.replace('-', '_')}.toml").read_text()
    for factor, warned in ((0.5, True), (2.0, False)):
        path = tmp_path / f"{factor}.toml"
        path.write_text(text + f"\n[actuators]\ntorque_limit = {float(factor * needed[j])!r}\n")
        assert main(["--check", "--scenario", str(path)]) == 0
        lines = [ln for ln in capsys.readouterr().err.splitlines() if "torque feasibility" in ln]
        if warned:
            assert len(lines) == 1 and "2 x its actuators.torque_limit" in lines[0], lines
            assert f"joint {robot_of(sc.robot).joint_names[j]!r}" in lines[0]
            assert "funnel row" in lines[0]
        else:
            assert not lines


def test_check_with_limits_measures_what_a_known_model_law_reads():
    """--check of the known-model scheme with torque limits evaluates the law's first command,
    which reads the measured M and C w: the check measures them for such a law (it raised
    an AssertionError before)."""
    import dataclasses
    import warnings

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.check import check

    sc = builtin_scenario("known-model")
    sc = dataclasses.replace(sc, actuators=dataclasses.replace(sc.actuators, torque_limit=0.05))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = check(sc)
    texts = [str(w.message) for w in caught]
    assert report.ok and any(t.startswith("torque demand at t = 0") for t in texts), texts
