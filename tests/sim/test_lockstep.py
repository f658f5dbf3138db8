"""Lock-step runs (issue 38): each run of a batch stepped together gives the result its own
single run gives, bit for bit; a run that stops leaves the others going; what lock-step does
not take is named."""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest

from ffsm_pin.control.registry import BUILTIN
from ffsm_pin.errors import ParameterError
from ffsm_pin.scenario import ActuatorSpec
from ffsm_pin.scenario.devices import SensorSpec
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.lockstep import lockstep_groups, lockstep_obstacle, simulate_lockstep
from ffsm_pin.sim.recorder import Recorder
from ffsm_pin.sim.run import prepare, simulate

NOISE = (("joints", 1e-4), ("joint_rates", 1e-3), ("base_attitude", 1e-4),
         ("base_rate", 1e-4), ("ee_pose", 1e-4), ("ee_velocity", 1e-3))  # fmt: skip
#: (built-in case, duration [s], a torque limit [N m] its commands exceed) per geometry: a
#: planar and a free-flyer robot
CASES = {"planar": ("case1", 0.6, 2.0), "spatial": ("spatial", 0.3, 0.2)}


#: Every built-in controller that offers lock-step batches (a next one is tested too).
LOCKSTEP_CONTROLLERS = [name for name, cls in BUILTIN.items() if hasattr(cls, "lockstep_handles")]


def _scenarios(case, duration, count, sensors=True, controller="lu-jia", **actuators):
    """``count`` cases of ``case`` as a campaign draws them: their own estimates, sensor and
    actuator seeds."""
    sc = builtin_scenario(case)
    ctrl = dataclasses.replace(sc.controller, type=controller)
    out = []
    for i in range(count):
        est = dataclasses.replace(ctrl.estimates, initial="perturbed", seed=10 + i)
        out.append(dataclasses.replace(
            sc, duration=duration, controller=dataclasses.replace(ctrl, estimates=est),
            sensors=SensorSpec(seed=20 + i, noise=NOISE) if sensors else sc.sensors,
            actuators=ActuatorSpec(seed=30 + i, **actuators),
        ))  # fmt: skip
    return out


def _prepared(scenarios):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [prepare(sc) for sc in scenarios]


def _assert_same_results(scenarios):
    """Lock-step against one by one: every recorded signal bit for bit, the same summary (but
    for the wall times), the same stop."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone = [simulate(s) for s in _prepared(scenarios)]
        together = simulate_lockstep(_prepared(scenarios))
    timing = {"wall_time_s", "steps_per_s"}
    for one, lock in zip(alone, together, strict=True):
        assert sorted(one.signals) == sorted(lock.signals)
        for key in one.signals:
            a, b = np.asarray(one.signals[key]), np.asarray(lock.signals[key])
            assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), key
        s1, s2 = ({k: v for k, v in r.summary().items() if k not in timing} for r in (one, lock))
        assert json.dumps(s1, sort_keys=True) == json.dumps(s2, sort_keys=True)  # (exact reprs)
        assert one.stop_reason == lock.stop_reason and one.steps == lock.steps
    return alone


@pytest.mark.parametrize("controller", LOCKSTEP_CONTROLLERS)
@pytest.mark.parametrize("geometry", sorted(CASES))
def test_lockstep_runs_equal_their_single_runs_bit_for_bit(geometry, controller):
    """Noisy sensors (each case's own stream), torque limits that saturate, perturbed
    estimates: the campaign's cases, for the paper's controller and both baselines."""
    case, duration, limit = CASES[geometry]
    limit = limit if controller == "lu-jia" else limit / 4  # (the baselines command less)
    scenarios = _scenarios(case, duration, 3, controller=controller, torque_limit=limit)
    alone = _assert_same_results(scenarios)
    assert all(r.completed for r in alone)
    assert any(r.summary()["saturation_fraction"] > 0 for r in alone)  # the limits acted


def test_lagged_rate_limited_actuators_and_exact_sensors_likewise():
    scenarios = _scenarios("case1", 0.4, 2, sensors=False, torque_limit=5.0,
                           time_constant=0.01, rate_limit=200.0)  # fmt: skip
    _assert_same_results(scenarios)


def test_a_run_that_stops_stops_alone_with_its_own_message():
    """A torque limit far below what a fast, narrow funnel needs: that case stops, the others
    run on; each as its single run."""
    scenarios = _scenarios("case1", 1.0, 3, torque_limit=3.0)
    perf = scenarios[1].performance
    fast = dataclasses.replace(perf.funnel_z, beta=(5.0,) * 3, rhoinf=(0.01,) * 3)
    narrow = dataclasses.replace(perf, funnel_z=fast)
    scenarios[1] = dataclasses.replace(scenarios[1], performance=narrow)
    alone = _assert_same_results(scenarios)
    assert not alone[1].completed  # (its estimates leave the physical set first)
    assert alone[0].completed and alone[2].completed


def test_what_lockstep_does_not_take_is_named_and_refused():
    sc = builtin_scenario("case1")
    delayed = dataclasses.replace(sc, duration=0.1, sensors=SensorSpec(delay=2))
    lj = sc.controller.lu_jia
    known = dataclasses.replace(sc, duration=0.1, controller=dataclasses.replace(
        sc.controller, lu_jia=dataclasses.replace(lj, scheme="known-model")))  # fmt: skip
    noisy = dataclasses.replace(sc, duration=0.1, actuators=ActuatorSpec(torque_noise=0.1))
    plain = dataclasses.replace(sc, duration=0.1)
    baseline = dataclasses.replace(
        plain, controller=dataclasses.replace(sc.controller, type="gjm-ct")
    )
    setups = _prepared([delayed, known, noisy, plain, baseline, plain, baseline])
    reasons = [lockstep_obstacle(s) for s in setups]
    assert "delay" in reasons[0] and "known-model" in reasons[1] and "noise" in reasons[2]
    assert reasons[3:] == [None] * 4
    assert lockstep_groups(setups) == [[3, 5], [4, 6]]  # (one controller class a group)
    with pytest.raises(ParameterError, match="run 0"):
        simulate_lockstep(setups[:1] + setups[3:])
    longer = _prepared([dataclasses.replace(sc, duration=0.2)])
    with pytest.raises(ParameterError, match="differ"):
        simulate_lockstep(setups[3:4] + longer)
    with pytest.raises(ParameterError, match="differ"):
        simulate_lockstep(setups[3:5])


def test_rows_written_at_once_are_the_rows_committed_one_by_one():
    """Recorder.write_rows across spills (a chunk of 7 rows) against commit."""
    shapes = {"t": (), "x": (2,), "s": (3,)}
    rng = np.random.default_rng(0)
    rows = {"t": np.arange(40.0), "x": rng.random((40, 2)), "s": rng.random((40, 3))}
    one = Recorder(shapes, 40, chunk_bytes=7 * 48, packed=["s"])
    for i in range(40):
        one.arrays["t"][one.i], one.arrays["x"][one.i] = rows["t"][i], rows["x"][i]
        one.block[one.i] = rows["s"][i]
        one.commit()
    many = Recorder(shapes, 40, chunk_bytes=7 * 48, packed=["s"])
    for start in (0, 3, 20):  # blocks of 3, 17 and 20 rows
        stop = {0: 3, 3: 20, 20: 40}[start]
        many.write_rows({k: rows[k][start:stop] for k in ("t", "x")}, rows["s"][start:stop])
    a, b = one.finish(), many.finish()
    assert a.spilled and b.spilled
    for key in shapes:
        assert np.array_equal(np.asarray(a[key]), np.asarray(b[key])), key


def test_groups_hold_no_more_recording_than_their_budget():
    """Five runs of one key: cut into groups whose recordings fit the budget, in order."""
    from ffsm_pin.sim.recording import recording_size

    setups = _prepared(_scenarios("case1", 0.1, 5, sensors=False))
    steps, row = recording_size(setups[0])
    one = (steps + 1) * row
    assert lockstep_groups(setups) == [[0, 1, 2, 3, 4]]
    assert lockstep_groups(setups, memory_bytes=2 * one) == [[0, 1], [2, 3]]  # (4: alone)
    assert lockstep_groups(setups, memory_bytes=2 * one, smallest=1) == [[0, 1], [2, 3], [4]]
