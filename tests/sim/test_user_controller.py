"""A user's controller through the one interface (control/interface.py, docs/controllers.md):
the shipped example runs planar and spatial, its recorded torque is its law on what it saw,
its signals are saved, and every way it can fail is a clean stop (exit 3) or bad input (exit 2).
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.control.registry import controller_class, known_types
from ffsm_pin.errors import ControllerLoadError
from ffsm_pin.scenario import SensorSpec
from ffsm_pin.scenario.file import load_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import prepare, simulate

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
EXAMPLE_FILES = {"planar": "joint_pd_planar.toml", "spatial": "joint_pd_spatial.toml"}


def _example(geometry: str, duration: float, **changes):
    sc = load_scenario(EXAMPLES / EXAMPLE_FILES[geometry])
    return dataclasses.replace(sc, duration=duration, **changes)


def _law(res, kp, kd, target, q_m, w):
    """The example's law (examples/joint_pd.py), evaluated here independently."""
    m3 = np.asarray(res["q_b"]).reshape(len(res["t"]), -1).shape[1]
    return kp * (target - q_m) - kd * w[:, m3:]


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
@pytest.mark.parametrize("noisy", [False, True])
def test_example_torque_is_its_law_on_what_it_saw(geometry, noisy):
    sensors = SensorSpec(seed=3, delay=2, noise=(("joints", 1e-3), ("joint_rates", 1e-3)))
    sc = _example(geometry, 0.3, **({"sensors": sensors} if noisy else {}))
    res = simulate(prepare(sc))
    assert res.completed and res.controller == "joint_pd.py:JointPD" and res.scheme is None
    n = np.asarray(res["u_cmd"]).shape[1]
    if noisy:
        q_m, w = np.asarray(res["meas_q_m"]), np.asarray(res["meas_w"])
        assert not np.array_equal(q_m, np.asarray(res["q"])[:, -n:])  # it saw other values
    else:
        q_m, w = np.asarray(res["q"])[:, -n:], np.asarray(res["w"])
    p = sc.controller.params
    target = np.asarray(p.get("target", np.asarray(res["q"])[0, -n:]), dtype=float)
    np.testing.assert_allclose(res["u_cmd"], _law(res, p["kp"], p["kd"], target, q_m, w),
                               rtol=0, atol=1e-13)  # fmt: skip
    # its own signal, under the ctrl_ prefix
    np.testing.assert_allclose(res["ctrl_joint_error"], target - q_m, rtol=0, atol=1e-15)
    assert np.array_equal(res["u_m"], res["u_cmd"])  # ideal actuators
    # what the paper's controller has and this one has not is simply absent
    for key in ("theta_d_hat", "w_hat", "sigma_min", "e"):
        assert key not in res
    s = res.summary()
    assert s["min_sigma"] is None and s["final_theta_d_error"] is None
    assert s["drift_P"] < 1e-9 and s["drift_L"] < 1e-9  # the plant is the plant


def test_funnels_judge_every_controller_but_stop_only_the_papers():
    """The joint PD ignores the reference: it leaves the end-effector funnel, and the run
    goes on (only a controller that needs its funnels stops there)."""
    res = simulate(prepare(_example("planar", 5.0)))
    s = res.summary()
    assert res.completed and s["funnel_ok_z"] is False
    t_exit = s["first_violation_t"]
    assert t_exit is not None and t_exit < 5.0
    # the flag comes from the true errors against the recorded bounds
    err, lo, hi = (np.asarray(res[k]) for k in ("err_z", "bound_z_lower", "bound_z_upper"))
    outside = ~np.all((err > lo) & (err < hi), axis=1)
    assert outside.any() and res["t"][np.argmax(outside)] == pytest.approx(t_exit)


def test_scenario_round_trip_keeps_type_and_params(tmp_path):
    sc = _example("spatial", 0.1)
    again = scenario_from_toml(scenario_to_toml(sc), source=tmp_path / "moved.toml")
    assert again.controller.params == sc.controller.params
    # the relative file is saved absolute, so the saved scenario runs from anywhere
    path, _, cls = again.controller.type.rpartition(":")
    assert Path(path).is_absolute() and Path(path) == EXAMPLES / "joint_pd.py" and cls == "JointPD"
    assert controller_class(again.controller.type).__name__ == "JointPD"


# ---------------------------------------------------------------------- failures, by CLI
def _scenario_with(tmp_path: Path, code: str | None, kind: str, duration: float = 0.2) -> Path:
    """examples/joint_pd_planar.toml with [controller] type = kind, and user.py = code."""
    text = (EXAMPLES / EXAMPLE_FILES["planar"]).read_text()
    text = text.replace('type = "joint_pd.py:JointPD"', f"type = {json.dumps(kind)}")
    text = text.replace("duration = 5.0", f"duration = {duration}")
    if code is not None:
        (tmp_path / "user.py").write_text(textwrap.dedent(code))
    (tmp_path / "joint_pd.py").write_text((EXAMPLES / "joint_pd.py").read_text())
    path = tmp_path / "sc.toml"
    path.write_text(text)
    return path


def _cli(scenario: Path, out: Path, env=None, fast=True):
    return subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(scenario), "--out", str(out),
         *(["--no-plots", "--no-html"] if fast else [])],
        capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip


RAISES = """
import numpy as np
class Boom:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        if meas.t >= 0.05:
            raise RuntimeError("gain schedule exhausted")
        return np.zeros(self.n)
"""
WRONG_SHAPE = """
import numpy as np
class Wide:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        return np.zeros(self.n + 1)
"""
NOT_FINITE = """
import numpy as np
class Nan:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        return np.full(self.n, np.nan) if meas.t > 0.1 else np.zeros(self.n)
"""

NEW_SIGNAL = """
import numpy as np
class Late:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        signals = {"gain": 1.0}
        if meas.t > 0.02:
            signals["extra"] = 2.0
        return np.zeros(self.n), signals
"""
DROPPED = """
import numpy as np
class Drops:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        signals = {"gain": 1.0}
        if meas.t < 0.02:
            signals["early"] = 2.0
        return np.zeros(self.n), signals
"""
RESHAPED = """
import numpy as np
class Grows:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        return np.zeros(self.n), {"gain": np.zeros(2 if meas.t > 0.03 else 1)}
"""


@pytest.mark.parametrize(
    "code, kind, words, t_stop",
    [
        (RAISES, "user.py:Boom", ["RuntimeError", "gain schedule exhausted"], 0.05),
        (NEW_SIGNAL, "user.py:Late", ["signals changed", "extra"], 0.021),
        (RESHAPED, "user.py:Grows", ["signals changed", "ValueError"], 0.031),
        (DROPPED, "user.py:Drops", ["signals changed", "early"], 0.02),
        (WRONG_SHAPE, "user.py:Wide", ["shape (5,)", "expected (4,)"], 0.0),
        (NOT_FINITE, "user.py:Nan", ["non-finite", "(4,)"], 0.101),
    ],
)
def test_a_failing_controller_stops_the_run_cleanly(tmp_path, code, kind, words, t_stop):
    out = tmp_path / "out"
    proc = _cli(_scenario_with(tmp_path, code, kind), out, fast=False)  # figures too
    assert proc.returncode == 3, proc.stderr
    lines = [x for x in proc.stderr.replace("\r", "\n").splitlines() if "stopped" in x]
    assert len(lines) == 1 and all(w in lines[0] for w in words), proc.stderr
    assert "Traceback" not in proc.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["completed"] is False and s["stop_cause"] == "controller"
    assert s["stop_time"] == pytest.approx(t_stop, abs=1e-9)
    with np.load(out / "trajectory.npz") as data:  # every period before the stop
        assert len(data["t"]) == round(t_stop / 1e-3)
        assert len(data["t"]) == 0 or data["t"][-1] == pytest.approx(t_stop - 1e-3, abs=1e-9)


HUGE = """
import numpy as np
class Huge:
    def __init__(self, ctx):
        self.n = ctx.n_joints
    def step(self, meas):
        return np.full(self.n, 1e9 if meas.t > 0.05 else 0.0)
"""


def test_a_plant_that_blows_up_stops_the_run_cleanly(tmp_path):
    """A finite but absurd torque (1e9 N m) is the controller's right; the plant's rates then
    exceed the loop's guard (1e4 rad/s) and the run stops with the plant's cause, the step
    that crossed it named, every row before it kept."""
    out = tmp_path / "out"
    proc = _cli(_scenario_with(tmp_path, HUGE, "user.py:Huge"), out)
    assert proc.returncode == 3, proc.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["completed"] is False and s["stop_cause"] == "nonfinite"
    assert "numerical blow-up" in s["stop_reason"] and "1e4 rad/s" in s["stop_reason"]
    with np.load(out / "trajectory.npz") as data:
        n = round(s["stop_time"] / 1e-3)  # rows 0 .. stop - dt: the state at stop_time is not
        assert len(data["t"]) == n and s["stop_time"] > 0.05
        assert np.abs(data["v"][:, 2:]).max() <= 1e4  # every recorded state passed the guard
        assert np.isfinite(data["q"]).all()


BAD_INPUT = [
    (None, "lu-jai", ["'lu-jia'", "did you mean"]),
    (None, "missing.py:Nope", ["file not found", "missing.py"]),
    ("class Other:\n    pass\n", "user.py:Mine", ["no class 'Mine'", "Other"]),
    ("class Mine:\n    def __init__(self, ctx):\n        pass\n", "user.py:Mine", ["step"]),
    (
        "class Mine:\n    def __init__(self, ctx):\n        raise KeyError('kp')\n"
        "    def step(self, meas):\n        return 0\n",
        "user.py:Mine",
        ["KeyError", "'kp'"],
    ),
    ("raise ImportError('no such dependency')\n", "user.py:Mine", ["ImportError"]),
    (None, "no_such_module_xyz:Ctrl", ["cannot import module", "no_such_module_xyz"]),
]


@pytest.mark.parametrize("code, kind, words", BAD_INPUT)
def test_a_controller_that_cannot_be_loaded_is_bad_input(tmp_path, code, kind, words):
    out = tmp_path / "out"
    proc = _cli(_scenario_with(tmp_path, code, kind), out)
    assert proc.returncode == 2, proc.stderr
    lines = [x for x in proc.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert all(w in lines[0] for w in words), lines[0]
    assert not (out / "summary.json").exists()


def test_unknown_type_lists_the_choices():
    with pytest.raises(ControllerLoadError) as info:
        controller_class("pd")
    assert all(repr(k) in str(info.value) for k in known_types())


def test_an_installed_package_adds_a_type_by_entry_point(tmp_path):
    """A pip-installed package's entry point in group ffsm_pin.controllers (here a
    distribution's metadata on PYTHONPATH, as pip would write it)."""
    site = tmp_path / "site"
    (site / "ffsm_plugin_demo-0.1.dist-info").mkdir(parents=True)
    (site / "ffsm_plugin_demo-0.1.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: ffsm-plugin-demo\nVersion: 0.1\n"
    )
    (site / "ffsm_plugin_demo-0.1.dist-info" / "entry_points.txt").write_text(
        "[ffsm_pin.controllers]\njoint-pd = ffsm_plugin_demo:JointPD\n"
    )
    (site / "ffsm_plugin_demo.py").write_text((EXAMPLES / "joint_pd.py").read_text())
    env = {**os.environ, "PYTHONPATH": str(site) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = tmp_path / "out"
    proc = _cli(_scenario_with(tmp_path, None, "joint-pd"), out, env=env)
    assert proc.returncode == 0, proc.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["controller"] == "joint-pd" and s["completed"]
    with np.load(out / "trajectory.npz") as data:
        assert "ctrl_joint_error" in data.files
    # and without the package the name is unknown, the message lists what there is
    proc = _cli(_scenario_with(tmp_path, None, "joint-pd"), tmp_path / "out2")
    assert proc.returncode == 2 and "'lu-jia'" in proc.stderr
