"""Scenario files that omit gains get derived ones; gains that violate a discrete-time
condition warn on a run and fail ``--check`` (docs/gains.md)."""

from __future__ import annotations

import subprocess
import sys

import pytest
import tomllib

from ffsm_pin.control.gains import step_problems
from ffsm_pin.scenario.file import BUILTIN, builtin_path, scenario_from_dict
from ffsm_pin.sim.run import prepare, simulate

# ----------------------------------------------------------------- every built-in robot
LU_JIA_GAINS = ("k_b", "k_z", "k_de", "k_d", "gamma_1", "gamma_2", "gamma_3")


# The paper's default adaptation gains (10) do not survive the capture of an unknown 40 kg box
# after an approach: theta_d-hat leaves the physical set about 1.2 s after the grasp and the run
# stops (adaptation = "physical" keeps it physical but the hand then leaves its funnel at about
# 6.9 s). The case ships gains of 0.1, as `capture` does (docs/capture.md). Strict: a change
# that makes the defaults hold here shows as a pass to turn into a plain case.
# `capture` with the defaults and its unknown box: the hand, held in the bus frame after the
# grasp, touches its position funnel for one recorded row at 5.39 s (by 0.1 mm of 18 mm; the
# inertial hold of before kept it). Every row is recorded here: a sampled recording (every
# 50th row, as this test had) missed that row.
_DEFAULTS_FAIL = {
    "capture-approach": "default adaptation gains drive theta_d-hat out of the physical set "
    "after the capture (docs/capture.md)",
    "capture": "default adaptation gains with an unknown box: the position funnel touched for "
    "one row after the grasp (docs/capture.md)",
}
_CASES = [
    pytest.param(n, marks=pytest.mark.xfail(reason=_DEFAULTS_FAIL[n], strict=True))
    if n in _DEFAULTS_FAIL
    else n
    for n in sorted(BUILTIN)
]


@pytest.mark.parametrize("name", _CASES)
def test_omitted_gains_keep_the_shipped_funnels(name):
    """Every built-in scenario with all its gains removed: the derived k_b, k_z and the
    paper's other defaults satisfy every condition, and the run keeps the funnels wherever
    the paper's scheme promises them (ppc, known-model; no-ppc and no-attitude are the
    paper's counter-examples and only have to run to the end)."""
    path = builtin_path(name)
    doc = tomllib.loads(path.read_text())
    for key in LU_JIA_GAINS:
        doc["controller"].pop(key, None)
    sc = scenario_from_dict(doc, source=path)
    c, perf = sc.controller, sc.performance
    m3 = len(perf.funnel_b.rho0)
    assert step_problems(c.lu_jia.gains, perf.funnel_b, perf.funnel_z, sc.dt, m3) == []
    run = simulate(prepare(sc))  # every row: a funnel touched for one row counts
    assert run.stop_cause is None
    summary = run.summary()
    if c.scheme in ("ppc", "known-model"):
        assert summary["funnel_ok_b"] and summary["funnel_ok_z"]


def test_explicit_gains_are_kept():
    path = builtin_path("spatial")
    sc = scenario_from_dict(tomllib.loads(path.read_text()), source=path)
    assert (sc.controller.lu_jia.gains.k_b, sc.controller.lu_jia.gains.k_z) == (2.5e-3, 1.6e-4)


# ----------------------------------------------------------------- command line
def _spatial_with(tmp_path, k_z: float):
    text = builtin_path("spatial").read_text()
    start = text.index("\nk_z = ")
    end = text.index("\n", start + 1)
    path = tmp_path / "s.toml"
    path.write_text(text[:start] + f"\nk_z = {k_z}" + text[end:])
    return path


def test_violating_gain_warns_on_a_run_and_fails_the_check(tmp_path):
    path = _spatial_with(tmp_path, 0.04)
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(path)]
    check = subprocess.run([*cmd, "--check"], capture_output=True, text=True)
    assert check.returncode == 2
    assert "error: controller.k_z = 0.04 is too large for dt = 0.002 s" in check.stderr
    run = subprocess.run(
        [*cmd, "--duration", "0.01", "--no-plots", "--no-html", "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert "warning: controller.k_z = 0.04 is too large" in run.stderr
    assert "k_z = 0.000142 satisfies it" in run.stderr


def test_sound_gains_pass_the_check(tmp_path):
    path = _spatial_with(tmp_path, 1.6e-4)
    done = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(path), "--check"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "too large" not in done.stderr
