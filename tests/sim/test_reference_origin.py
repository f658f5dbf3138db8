"""``[reference] origin = "initial"``: references relative to the robot's start (issue 19)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.scenario.file import builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import Sensor, prepare, simulate


def _start(sc):
    """z_e(0) and q_b(0) of a scenario's robot, measured as the run measures them."""
    setup = prepare(sc)
    meas = Sensor(setup.robot, setup.model, full_model=False).measure(0.0, setup.q0, setup.v0)
    return meas.z_e, np.atleast_1d(meas.q_b), setup.model.m2


def _relative(sc):
    """The same reference written relative to the start: c - z_e(0), R(q0)^T R(c) for MRPs."""
    z0, qb0, m2 = _start(sc)
    ref = sc.reference
    c = np.array([comp.c for comp in ref.ee])
    rel = c.copy()
    rel[:m2] = c[:m2] - z0[:m2]
    base = np.array(ref.base_attitude) - qb0
    if len(qb0) == 3:  # MRPs: the rotation from the initial attitude
        if len(c) > m2:
            R0 = mrp.to_rotation(z0[m2:])
            rel[m2:] = mrp.from_rotation(R0.T @ mrp.to_rotation(c[m2:]))
        base = mrp.from_rotation(mrp.to_rotation(qb0).T @ mrp.to_rotation(ref.base_attitude))
    elif len(c) > m2:
        rel[m2:] = c[m2:] - z0[m2:]
    ee = tuple(dataclasses.replace(comp, c=float(v)) for comp, v in zip(ref.ee, rel, strict=True))
    new = dataclasses.replace(ref, ee=ee, base_attitude=tuple(base), origin="initial")
    return dataclasses.replace(sc, reference=new)


@pytest.mark.parametrize("case", ["case1", "spatial", "spatial-pose"])
def test_relative_reference_resolves_to_the_absolute_one(case):
    sc = dataclasses.replace(builtin_scenario(case), duration=0.05)
    rel = _relative(sc)
    assert rel.reference.origin == "initial" and rel.reference != sc.reference
    setup = prepare(rel)
    got = setup.scenario.reference
    assert got.origin == "absolute"
    t = np.linspace(0.0, 20.0, 41)
    for a, b in zip(sc.reference.sample(t), got.sample(t), strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got.base_attitude, sc.reference.base_attitude, atol=1e-12)
    # a short run follows the same trajectory (to the rounding of c - z0 + z0)
    a, b = simulate(prepare(sc)), simulate(setup)
    for key in ("q", "u_m", "err_z"):
        np.testing.assert_allclose(b[key], a[key], rtol=1e-9, atol=1e-9, err_msg=key)


def test_the_saved_scenario_is_the_resolved_absolute_one(tmp_path):
    rel = _relative(dataclasses.replace(builtin_scenario("case1"), duration=0.05))
    assert 'origin = "initial"' in scenario_to_toml(rel)  # unresolved: written as given
    assert scenario_from_toml(scenario_to_toml(rel)).reference == rel.reference
    resolved = prepare(rel).scenario
    text = scenario_to_toml(resolved)
    assert "\norigin =" not in text
    assert scenario_from_toml(text).reference == resolved.reference


def test_bad_origin_is_one_error_line(tmp_path):
    text = scenario_to_toml(dataclasses.replace(builtin_scenario("case1"), duration=0.01))
    text = text.replace("[reference]\n", '[reference]\norigin = "start"\n')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(path), "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "reference.origin" in errors[0] and "'initial'" in errors[0]
