"""Actuator limits, lag and noise between the controller and the plant (issue 17)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario import ActuatorSpec
from ffsm_pin.scenario.file import builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.actuators import Actuators
from ffsm_pin.sim.run import prepare, simulate


def _run(case="case1", duration=0.5, **actuators):
    sc = builtin_scenario(case)
    sc = dataclasses.replace(sc, duration=duration, actuators=ActuatorSpec(**actuators))
    return simulate(prepare(sc))


def test_ideal_actuators_apply_the_command_unchanged():
    res = _run()
    assert np.array_equal(res["u_cmd"], res["u_m"])
    assert res.summary()["saturation_fraction"] == 0.0
    assert res.summary()["max_abs_u_cmd"] == res.summary()["max_abs_u"]


def test_limits_hold_and_the_saturation_fraction_is_what_the_rows_show():
    limit = np.array([3.0, 2.0, 1.5, 1.0])  # far below case 1's commands (tens of N m)
    res = _run(torque_limit=tuple(limit))
    u_m, u_cmd = np.asarray(res["u_m"]), np.asarray(res["u_cmd"])
    assert np.all(np.abs(u_m) <= limit)
    assert np.any(np.abs(u_cmd) > limit)  # the limit was needed
    at_limit = np.any(np.abs(u_m) >= limit, axis=1)
    s = res.summary()
    assert s["saturation_fraction"] == pytest.approx(at_limit.mean(), abs=0.0)
    assert 0 < s["saturation_fraction"] <= 1
    # ideal actuators: the same clipping applied to the command
    assert np.array_equal(u_m, np.clip(u_cmd, -limit, limit))


def test_a_recovery_reads_the_saturation_from_the_rows_as_the_loop_counts_it():
    """``Actuators.saturation_of_rows`` (what ``--recover`` reports) on a run's recorded
    ``u_m``: the loop's ``saturation_fraction`` and ``saturation_per_joint``, exactly, with
    the limit cutting in some periods and not in all; NaN without rows."""
    sc = builtin_scenario("case1")
    spec = ActuatorSpec(torque_limit=(10.0, 8.0, 5.0, 3.0))
    setup = prepare(dataclasses.replace(sc, duration=0.5, actuators=spec))
    res = simulate(setup)
    s = res.summary()
    assert 0.0 < s["saturation_fraction"] < 1.0
    fraction, per_joint = setup.actuators.saturation_of_rows(res.signals.blocks)
    assert fraction == s["saturation_fraction"]
    assert per_joint == s["saturation_per_joint"]
    empty = setup.actuators.saturation_of_rows(lambda keys: iter(()))
    assert np.isnan(empty[0]) and np.isnan(empty[1]).all()


def test_urdf_limits_equal_the_same_numbers_given_explicitly():
    """planar5's URDF gives every joint <limit effort="1000">: "urdf" = 1000 N m each."""
    a = _run("planar5", 0.3, torque_limit="urdf")
    b = _run("planar5", 0.3, torque_limit=(1000.0,) * 5)
    for key in ("u_m", "u_cmd", "q", "v"):
        assert np.array_equal(a[key], b[key]), key


def test_urdf_limits_need_efforts():
    with pytest.raises(ScenarioError, match="effort"):
        Actuators(ActuatorSpec(torque_limit="urdf"), 2, 1e-3, np.array([10.0, 0.0]), ("a", "b"))


def test_lag_step_response_is_the_first_order_closed_form():
    """Command held at c from rest: x_k = c (1 - exp(-k dt / tau)) at every control period."""
    dt, tau, c = 1e-3, 0.05, np.array([2.0, -1.0])
    act = Actuators(ActuatorSpec(time_constant=tau), 2, dt)
    k = np.arange(1, 301)
    x = np.array([act.apply(c) for _ in k])
    np.testing.assert_allclose(x, c * (1 - np.exp(-k * dt / tau))[:, None], rtol=1e-12, atol=0)


def test_rate_limit_bounds_every_change():
    dt, rate = 1e-3, 50.0
    act = Actuators(ActuatorSpec(rate_limit=rate), 3, dt)
    rng = np.random.default_rng(1)
    u = np.array([act.apply(10 * rng.standard_normal(3)) for _ in range(200)])
    steps = np.abs(np.diff(np.vstack([np.zeros(3), u]), axis=0))
    assert np.all(steps <= rate * dt * (1 + 1e-12))
    assert np.any(steps >= rate * dt * (1 - 1e-12))  # the limit was active


def test_torque_noise_is_seeded_with_its_standard_deviation():
    sigma = np.array([0.5, 2.0])
    draw = lambda seed: np.array(  # noqa: E731
        [Actuators(ActuatorSpec(torque_noise=tuple(sigma), seed=seed), 2, 1e-3).apply(np.ones(2))]
    )
    assert np.array_equal(draw(3), draw(3)) and not np.array_equal(draw(3), draw(4))
    act = Actuators(ActuatorSpec(torque_noise=tuple(sigma), seed=7), 2, 1e-3)
    n = np.array([act.apply(np.zeros(2)) for _ in range(20000)])
    np.testing.assert_allclose(n.std(axis=0), sigma, rtol=0.03)  # 20000 samples: ~0.5 % s.e.
    assert np.all(np.abs(n.mean(axis=0)) < 4 * sigma / np.sqrt(len(n)))


def test_actuator_keys_round_trip_through_toml():
    sc = dataclasses.replace(
        builtin_scenario("case1"),
        actuators=ActuatorSpec(torque_limit=(5.0, 4.0, 3.0, 2.0), rate_limit=100.0,
                               time_constant=0.01, torque_noise=0.1, seed=3),
    )  # fmt: skip
    assert scenario_from_toml(scenario_to_toml(sc)).actuators == sc.actuators


@pytest.mark.parametrize(
    "table, needle",
    [
        ("torque_limit = -1.0", "actuators.torque_limit"),
        ('torque_limit = "max"', "actuators.torque_limit = 'max' unknown"),
        ("torque_noise = -0.1", "actuators.torque_noise"),
        ("rate_limit = [1.0, 2.0]", "actuators.rate_limit: 2 values, expected 1 or 4"),
        ("time_constant = -0.5", "actuators.time_constant"),
    ],
)
def test_bad_actuator_input_is_one_error_line(table, needle, tmp_path):
    text = scenario_to_toml(dataclasses.replace(builtin_scenario("case1"), duration=0.01))
    path = tmp_path / "bad.toml"
    path.write_text(text + f"\n[actuators]\n{table}\n")
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(path)]
    cmd += ["--out", str(tmp_path / "o")]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    errors = [ln for ln in lines if ln.startswith("error:")]
    assert len(errors) == 1 and needle in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize(
    "spec",
    [
        ActuatorSpec(torque_limit=0.8),
        ActuatorSpec(time_constant=0.02),
        ActuatorSpec(rate_limit=(30.0, 0.0, 10.0)),  # one joint without a rate limit
        ActuatorSpec(torque_noise=0.05, seed=4),
        ActuatorSpec(
            torque_limit=(0.5, 1.0, 2.0),
            rate_limit=40.0,
            time_constant=0.01,
            torque_noise=(0.02, 0.0, 0.1),
            seed=9,
        ),  # fmt: skip
    ],
)
def test_compiled_step_equals_the_numpy_reference_bit_for_bit(spec):
    """The compiled actuator step (sim/_actuator_kernel.py) against apply_reference, over
    3000 periods of a random command (more than two blocks of drawn noise)."""
    fast, ref = Actuators(spec, 3, 1e-3), Actuators(spec, 3, 1e-3)
    u = np.random.default_rng(2).normal(0.0, 1.5, (3000, 3))
    for k in range(len(u)):
        a = fast.apply(u[k])
        b = ref.apply_reference(u[k])
        assert np.array_equal(a, b), k
        assert fast.last_saturated == ref.saturated(b), k
        assert np.array_equal(fast.x, ref.x), k
