"""Sensor noise and delay act on what the controller sees, never on the plant (issue 17)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ffsm_pin.scenario.devices import NOISE_KEYS, SensorSpec
from ffsm_pin.scenario.file import builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import prepare, simulate

CASES = [("case1", 0.4), ("spatial", 0.1)]


def _run(case, duration, **sensors):
    sc = dataclasses.replace(
        builtin_scenario(case), duration=duration, sensors=SensorSpec(**sensors)
    )
    return simulate(prepare(sc))


@pytest.mark.parametrize("case, duration", CASES)
def test_noise_is_seeded_and_has_its_standard_deviation(case, duration):
    noise = (("joints", 1e-3), ("joint_rates", 2e-3), ("ee_pose", 5e-4))
    a = _run(case, duration, seed=1, noise=noise)
    b = _run(case, duration, seed=1, noise=noise)
    c = _run(case, duration, seed=2, noise=noise)
    for key in ("meas_q_m", "q", "u_cmd"):
        assert np.array_equal(a[key], b[key]), key
    assert not np.array_equal(a["meas_q_m"], c["meas_q_m"])
    m3 = np.asarray(a["q_b"]).reshape(len(a["t"]), -1).shape[1]
    for meas, true, sigma in (
        ("meas_q_m", np.asarray(a["q"])[:, -np.asarray(a["meas_q_m"]).shape[1] :], 1e-3),
        ("meas_w", np.asarray(a["w"]), None),
        ("meas_z_e", np.asarray(a["z_e"]), 5e-4),
    ):
        err = np.asarray(a[meas]) - true
        if sigma is None:  # w = (w_b, w_m): no noise on w_b, 2e-3 on w_m
            assert np.array_equal(err[:, :m3], np.zeros_like(err[:, :m3]))
            err, sigma = err[:, m3:], 2e-3
        n = err.size
        assert abs(err.std() / sigma - 1) < 5 / np.sqrt(2 * n), meas  # ~5 standard errors
        assert abs(err.mean()) < 5 * sigma / np.sqrt(n), meas


@pytest.mark.parametrize("case, duration", CASES)
def test_delay_gives_the_state_of_d_periods_before(case, duration):
    d = 3
    res = _run(case, duration, delay=d)
    t = np.asarray(res["t"])
    for meas, true in (("meas_q_m", None), ("meas_w", "w"), ("meas_z_e", "z_e")):
        seen = np.asarray(res[meas])
        truth = np.asarray(res[true]) if true else np.asarray(res["q"])[:, -seen.shape[1] :]
        assert np.array_equal(seen[d:], truth[:-d]), meas
        assert np.array_equal(seen[:d], np.repeat(truth[:1], d, axis=0)), meas  # held at t = 0
    assert len(t) > 10


@pytest.mark.parametrize("case, duration", CASES)
def test_noise_leaves_the_plant_exact(case, duration):
    """Momentum drift is what the plant's projection gives, with or without sensor noise."""
    exact = _run(case, duration)
    noisy = _run(case, duration, seed=4, noise=tuple((k, 1e-4) for k in NOISE_KEYS))
    d0, d1 = exact.drift(), noisy.drift()
    assert d1[0] < 1e-10 and d1[1] < 1e-10
    assert max(d1) < 100 * max(max(d0), 1e-15)
    assert "meas_w" not in exact.signals and "meas_w" in noisy.signals
    # the recorded errors are the true ones: z_e - z_e_d, not the controller's noisy view
    nt = np.asarray(noisy["err_z"]).shape[1]
    err = np.asarray(noisy["z_e"])[:, :nt] - np.asarray(noisy["z_e_d"])
    if nt == 3:  # planar attitude wrapped
        err[:, 2] = (err[:, 2] + np.pi) % (2 * np.pi) - np.pi
    np.testing.assert_allclose(noisy["err_z"], err, atol=1e-12)


def test_sensor_keys_round_trip_through_toml():
    sc = dataclasses.replace(
        builtin_scenario("case1"),
        sensors=SensorSpec(seed=5, delay=2, noise=(("joints", (1e-3, 2e-3, 3e-3, 4e-3)),
                                                   ("ee_velocity", 0.01))),
    )  # fmt: skip
    assert scenario_from_toml(scenario_to_toml(sc)).sensors == sc.sensors


@pytest.mark.parametrize("delay", [0, 2])
@pytest.mark.parametrize("m3", [1, 3])
def test_a_controller_writing_into_what_it_is_given_changes_nothing_later(delay, m3):
    """What :meth:`Sensors.observe` hands out may be written into by a controller: the exact
    measurement and every later hand-out stay as a sensor nobody wrote into gives them (with
    no delay the noisy arrays are new each period and handed out without copies)."""
    from ffsm_pin.control.interface import Measurement
    from ffsm_pin.sim.sensors import Sensors

    n = 4
    spec = SensorSpec(seed=3, delay=delay, noise=tuple((k, 1e-3) for k in NOISE_KEYS))
    clean, written = Sensors(spec, n, m3, 3), Sensors(spec, n, m3, 3)
    rng = np.random.default_rng(0)
    for k in range(6):
        q_b = float(rng.normal()) if m3 == 1 else rng.normal(size=3)
        meas = Measurement(0.01 * k, q_b, rng.normal(size=n), rng.normal(size=n + m3),
                           rng.normal(size=3), rng.normal(size=3), None, None)  # fmt: skip
        kept = [np.copy(x) for x in meas[1:6]]
        a, b = clean.observe(meas), written.observe(meas)
        for x, y in zip(a[1:6], b[1:6], strict=True):
            np.testing.assert_array_equal(x, y)
        for y in b[1:6]:  # the controller writes into every array it was given
            if isinstance(y, np.ndarray):
                y[:] = np.nan
        for x, y in zip(kept, meas[1:6], strict=True):
            np.testing.assert_array_equal(x, y)  # the exact measurement untouched
