"""A capture run recovered from its spool (issue 40; ``ffsm_pin/sim/recover.py``,
``ffsm_pin/sim/system_signals.py``): the grasp the spool noted (``capture.json``), the whole
system's momentum (robot, box, wheels) and every capture key, as a finished run of the same
length has them.

A kill is stood in for by copying the spool while the run goes on, after the grasp (its
header's process id set to 0, a process that is not running)."""

from __future__ import annotations

import dataclasses
import json
import shutil
import warnings

import numpy as np
import pytest

import ffsm_pin.sim.recorder as recorder
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.sim.capture_run import CAPTURE_KEYS
from ffsm_pin.sim.held_truth import HELD_TRUTH_KEYS
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.recover import recover
from ffsm_pin.sim.setup import prepare

WHEELS = (
    '\n[robot.satellite.wheels]\ninertia = 0.05\ncontrol = "attitude-pd-after-capture"\n'
    "kp = 20.0\nkd = 100.0\nmax_torque = 0.004\n"
)
CUT = 3.4  # [s], after the capture case's grasp (3.062 s)


class CopySpool:
    """The run's controller, copying the run's spool to ``dest`` at its first period at or
    after ``at`` [s] (the state a kill would leave)."""

    def __init__(self, inner, spools, dest, at: float) -> None:
        self.inner, self.spools, self.dest, self.at = inner, spools, dest, at
        self.done = False

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def step(self, meas):
        if not self.done and meas.t >= self.at:
            (spool,) = self.spools.glob(".ffsm-spool-*")
            shutil.copytree(spool, self.dest)
            header = json.loads((self.dest / "spool.json").read_text())
            header["pid"] = 0  # (no such process: the run is over)
            (self.dest / "spool.json").write_text(json.dumps(header))
            self.done = True
        return self.inner.step(meas)


def _setup(text: str, duration: float):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return prepare(dataclasses.replace(scenario_from_toml(text), duration=duration))


@pytest.mark.parametrize("wheels", ["", WHEELS], ids=["capture", "capture-wheels"])
def test_a_killed_capture_run_recovers_its_capture(tmp_path, monkeypatch, wheels):
    """The recovered run's rows and its capture keys (captured, capture time, impulse, relative
    speed, energy), detumble time, final estimate errors against the merged robot, truths after
    the grasp, the whole system's P and L and the saturation fractions (joints and wheels, the
    wheels' torque limit cutting) equal those of a run of the same scenario ending at the
    recovered run's last row, bit for bit; without the fix the recovery had no capture and the
    robot's momentum alone, and NaN fractions."""
    monkeypatch.setattr(recorder, "CHUNK_BYTES", 2**16)  # spill early
    # joint 1 limited to 0.5 N m (its start reaches 0.84 N m): the first periods cut
    text = (
        builtin_path("capture")
        .read_text()
        .replace(
            'torque_limit = "urdf"', "torque_limit = [0.5, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]", 1
        )
    )
    assert "torque_limit = [0.5" in text
    text += wheels
    setup = _setup(text, 3.6)
    dest = tmp_path / "killed" / ".ffsm-spool-copy"
    setup.controller = CopySpool(setup.controller, tmp_path, dest, CUT)
    simulate(setup, spool_dir=tmp_path)
    assert (dest / "capture.json").is_file()
    (got,) = recover(dest.parent)
    result = got.result
    t_last = float(result["t"][-1])
    assert 3.1 < t_last <= CUT
    full = simulate(_setup(text, t_last))
    rows = len(result["t"])
    assert len(full["t"]) == rows
    keys = ["t", "q", "v", "u_m", "P", "L", "target_pose", "target_twist", *HELD_TRUTH_KEYS]
    if wheels:
        keys.append("wheel_momentum")
    for key in keys:
        np.testing.assert_array_equal(result[key], full[key], err_msg=key)
    mine, theirs = result.summary(), full.summary()
    assert mine["captured"] and mine["stop_cause"] == "recovered"
    for key in (*CAPTURE_KEYS, "detumble_time", "final_theta_z_error", "final_theta_d_error",
                "drift_P", "drift_L"):  # fmt: skip
        assert mine[key] == theirs[key], key
    assert mine["drift_L"] < 1e-12 * np.abs(full["L"]).max()
    # the saturation fractions, read from the recorded torques and commands, are the loop's
    assert 0.0 < mine["saturation_fraction"] < 1.0
    assert mine["saturation_per_joint"] == theirs["saturation_per_joint"]
    assert mine["saturation_fraction"] == theirs["saturation_fraction"]
    if wheels:  # the limit cuts in some periods after the grasp, not in all
        assert 0.0 < mine["wheel_saturation_fraction"] < 1.0
        assert mine["wheel_saturation_fraction"] == theirs["wheel_saturation_fraction"]


def test_a_killed_approach_run_recovers_its_reference(tmp_path, monkeypatch):
    """``capture-approach`` with wheels, killed after its grasp: the reference the controller
    was given (the approach's, from the target sensor's seeded noise and the prediction) is
    rebuilt from the rows and equals the finished run's to the rounding of the recorded
    attitude quaternion; the task errors against it too; the capture keys and the whole
    system's momentum bit for bit. Without the replay the recovered reference was the
    ``[reference]``'s (the hand holding its place), centimetres off."""
    monkeypatch.setattr(recorder, "CHUNK_BYTES", 2**16)
    text = builtin_path("capture-approach").read_text() + WHEELS
    cut = 5.0  # [s], after the grasp (4.86 s)
    setup = _setup(text, cut + 0.2)
    dest = tmp_path / "killed" / ".ffsm-spool-copy"
    setup.controller = CopySpool(setup.controller, tmp_path, dest, cut)
    simulate(setup, spool_dir=tmp_path)
    (got,) = recover(dest.parent)
    result = got.result
    t_last = float(result["t"][-1])
    full = simulate(_setup(text, t_last))
    assert len(full["t"]) == len(result["t"])
    mine, theirs = result.summary(), full.summary()
    assert mine["captured"] and theirs["captured"]
    for key in (*CAPTURE_KEYS, "drift_P", "drift_L"):
        assert mine[key] == theirs[key], key
    for key in ("q", "v", "P", "L", "target_pose", "target_twist", "wheel_momentum"):
        np.testing.assert_array_equal(result[key], full[key], err_msg=key)
    # (the error z_e - z_e_d rounds at the scale of z_e_d)
    for key, scale in (("z_e_d", "z_e_d"), ("z_e_d_dot", "z_e_d_dot"), ("err_z", "z_e_d")):
        assert np.isfinite(result[key]).all(), key
        atol = 1e-13 * np.abs(full[scale]).max()
        np.testing.assert_allclose(result[key], full[key], rtol=0, atol=atol, err_msg=key)
    # the [reference]'s own (what the recovery gave before) is far from it
    base = setup.scenario.reference
    assert np.abs(np.asarray(base.ee_pose(t_last)) - full["z_e_d"][-1]).max() > 1e-2


def test_an_approach_run_recorded_sparsely_has_no_reference(tmp_path, monkeypatch):
    """Recorded every 2 periods, the sensor's delay buffer lacks its states: the recovered
    reference is NaN, and an event of the result says why."""
    monkeypatch.setattr(recorder, "CHUNK_BYTES", 2**14)
    text = builtin_path("capture-approach").read_text()
    setup = _setup(text, 0.6)
    dest = tmp_path / "killed" / ".ffsm-spool-copy"
    setup.controller = CopySpool(setup.controller, tmp_path, dest, 0.5)
    simulate(setup, spool_dir=tmp_path, record_every=2)
    (got,) = recover(dest.parent)
    assert np.isnan(got.result["z_e_d"]).all()
    assert any("every 2 periods" in e for e in got.result.events)


@pytest.mark.parametrize("every", [2, 3])
def test_a_capture_run_recorded_sparsely_recovers_its_reference_until_the_grasp(
    tmp_path, monkeypatch, every
):
    """``capture`` (its hold without ``[approach]``) recorded every 2 or 3 periods, killed
    after the grasp (at period 1531, recorded by neither): the recovered reference equals the
    finished run's on every row before the grasp, bit for bit (the scenario's reference), is
    NaN from the grasp on (the hold's start was not recorded), and an event says why."""
    monkeypatch.setattr(recorder, "CHUNK_BYTES", 2**14)
    text = builtin_path("capture").read_text()
    setup = _setup(text, CUT + 0.2)
    dest = tmp_path / "killed" / ".ffsm-spool-copy"
    setup.controller = CopySpool(setup.controller, tmp_path, dest, CUT)
    full = simulate(setup, spool_dir=tmp_path, record_every=every)
    (got,) = recover(dest.parent)
    result = got.result
    t, t_c = result["t"], result.summary()["capture_time"]
    assert round(t_c / setup.scenario.dt) % every != 0
    before, after = t < t_c, t >= t_c
    assert before.sum() > 100 and after.any()
    np.testing.assert_array_equal(result["z_e_d"][before], full["z_e_d"][: len(t)][before])
    assert np.isnan(result["z_e_d"][after]).all()
    assert any(f"every {every} periods, not the grasp's" in e for e in result.events)
