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
    "kp = 20.0\nkd = 100.0\n"
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
    the grasp and the whole system's P and L equal those of a run of the same scenario ending
    at the recovered run's last row, bit for bit; without the fix the recovery had no capture
    and the robot's momentum alone."""
    monkeypatch.setattr(recorder, "CHUNK_BYTES", 2**16)  # spill early
    text = builtin_path("capture").read_text() + wheels
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
    if wheels:  # (the wheels' commands are not recorded: the fraction is not known)
        assert mine["wheel_saturation_fraction"] is None or np.isnan(
            mine["wheel_saturation_fraction"]
        )
