"""``--check`` on a run with a target (issue 40): the target out of reach, no capture on the
predicted motion, an impact beyond the joints' torque limits (``ffsm_pin/sim/capture_check.py``).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude.mrp import to_rotation
from ffsm_pin.scenario.file import builtin_path, builtin_scenario, scenario_from_toml
from ffsm_pin.sim.capture_check import (
    CaptureWarning,
    capture_warnings,
    detumble_need,
    predict_capture,
)
from ffsm_pin.sim.check import check
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.setup import prepare


def _setup(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return prepare(scenario)


def _target(name: str, **changes):
    sc = builtin_scenario(name)
    assert sc.target is not None
    return dataclasses.replace(sc, target=dataclasses.replace(sc.target, **changes))


def _check_warnings(scenario) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = check(scenario)
    assert report.ok, report.problems
    return [str(w.message) for w in caught if w.category is CaptureWarning]


@pytest.mark.parametrize("name", ["capture", "capture-approach", "target-tumbling"])
def test_the_shipped_cases_get_no_warning(name):
    assert _check_warnings(builtin_scenario(name)) == []


def test_the_predicted_capture_of_the_capture_case():
    """The box's grasp point starts 4 cm from the hand, which holds its place, and closes at
    1 cm/s (its spin is about the line between them): within the 1 cm tolerance at 3 s."""
    pred = predict_capture(_setup(builtin_scenario("capture")))
    assert pred is not None and pred.capture_time is not None
    assert abs(pred.capture_time - 3.0) < 0.1  # (the spin is mostly, not only, about it)
    assert abs(pred.distance[0] - 0.04) < 1e-3
    assert pred.reachable.all()


def test_a_target_the_reference_never_meets_is_warned_of():
    """'capture-approach' without its [approach]: the box starts 25 cm away and closes by
    10 cm in 10 s; with it, the blend takes the hand there."""
    sc = _target("capture-approach", approach=None)
    (line,) = _check_warnings(sc)
    assert line.startswith("no capture predicted") and "capture.tolerance_position" in line
    assert "\n" not in line
    pred = predict_capture(_setup(sc))
    assert pred is not None and pred.capture_time is None
    assert pred.distance.min() == pytest.approx(0.25 - 0.01 * 10.0, abs=5e-3)


def test_a_target_beyond_the_reach_is_warned_of():
    sc = _target("target-tumbling", position=(5.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0))
    lines = _check_warnings(sc)
    assert any(x.startswith("target out of reach") for x in lines), lines
    pred = predict_capture(_setup(sc))
    assert pred is not None and not pred.reachable.any()


def test_an_impact_beyond_the_torque_limits_is_warned_of():
    """A 100 times heavier box arriving 10 times faster (tolerance_velocity raised so that it
    is grasped): the stopping torques exceed the Panda's limits; they grow with the mass."""
    base = builtin_scenario("capture-approach")
    assert base.target is not None and base.target.capture is not None
    capture = dataclasses.replace(base.target.capture, tolerance_velocity=1.0)
    fast = tuple(10.0 * x for x in base.target.velocity)
    heavy = _target("capture-approach", mass=4000.0, velocity=fast, capture=capture)
    lines = _check_warnings(heavy)
    assert len(lines) == 1 and lines[0].startswith("impact beyond the torque limits"), lines
    assert "panda_joint" in lines[0] and "\n" not in lines[0]
    light = _target("capture-approach", mass=40.0, velocity=fast, capture=capture)
    assert _check_warnings(light) == []
    p_heavy, p_light = predict_capture(_setup(heavy)), predict_capture(_setup(light))
    assert p_heavy is not None and p_light is not None
    assert p_heavy.capture_time == p_light.capture_time  # (the same motion)
    assert p_heavy.stopping_torque is not None and p_light.stopping_torque is not None
    ratio = np.abs(p_heavy.stopping_torque).max() / np.abs(p_light.stopping_torque).max()
    assert ratio > 10.0


def test_no_target_no_prediction():
    setup = _setup(builtin_scenario("spatial-realistic"))
    assert predict_capture(setup) is None and capture_warnings(setup) == []


def _with_wheels(table: str):
    return scenario_from_toml(
        builtin_path("capture").read_text() + "\n[robot.satellite.wheels]\ninertia = 0.05\n" + table
    )


def _system_momentum(setup) -> np.ndarray:
    """L of robot and target about their common CoM, world frame, by hand: each body's own
    L about its CoM (the plant's for the robot, R I w for the box) plus m (c - c_sys) x v."""
    plant = Plant(setup.robot)
    P_r, L_r = plant.split_momentum(plant.momentum(setup.q0, setup.v0))
    m_r, box, state = plant.mass, setup.target, setup.target_state
    c_r = pin.centerOfMass(setup.robot.model, setup.robot.model.createData(), setup.q0)
    c_t = state.com_position(box)
    c = (m_r * c_r + box.mass * c_t) / (m_r + box.mass)
    R = state.pose.rotation
    L_t = R @ np.asarray(box.inertia) @ state.angular_velocity
    return L_r + np.cross(c_r - c, P_r) + L_t + np.cross(c_t - c, box.mass * state.velocity)


def test_wheels_too_small_for_the_detumble_are_warned_of():
    """With axes "xyz" the wheels must hold R_d^T L, L the system's angular momentum (by hand)
    and R_d the desired bus attitude: a max_momentum 10 % below the largest component warns,
    naming the key and that wheel; 10 % above does not."""
    setup = _setup(_with_wheels(""))
    R_d = to_rotation(np.asarray(setup.scenario.reference.base_attitude, dtype=float))
    expected = R_d.T @ _system_momentum(setup)
    need = detumble_need(setup)
    assert need is not None and np.abs(need - expected).max() < 1e-12 * np.abs(expected).max()
    i = int(np.argmax(np.abs(expected)))
    big = float(np.abs(expected[i]))
    assert big > 0.01  # (the box's spin: |L| about 0.03 N m s)
    (line,) = _check_warnings(_with_wheels(f"max_momentum = {0.9 * big}\n"))
    assert "robot.satellite.wheels.max_momentum" in line and f"wheel {i}," in line
    assert "\n" not in line
    assert _check_warnings(_with_wheels(f"max_momentum = {1.1 * big}\n")) == []


def test_the_detumble_need_of_redundant_wheels_is_the_least_norm_allocation():
    """Four wheels (a pyramid): A h = R_d^T L and h has no part in A's null space."""
    table = "axes = [[1.0, -1.0, 0.0, 0.0], [0.0, 0.0, 1.0, -1.0], [1.0, 1.0, 1.0, 1.0]]\n"
    setup = _setup(_with_wheels(table))
    wheels = setup.scenario.robot.wheels
    need = detumble_need(setup)
    assert need is not None and need.shape == (4,)
    R_d = to_rotation(np.asarray(setup.scenario.reference.base_attitude, dtype=float))
    expected = R_d.T @ _system_momentum(setup)
    assert np.abs(wheels.axes @ need - expected).max() < 1e-12 * np.abs(expected).max()
    null = np.linalg.svd(wheels.axes)[2][3]  # A's null space (one vector)
    assert abs(null @ need) < 1e-12 * np.abs(need).max()


def test_wheels_too_weak_for_the_detumble_are_warned_of():
    """A wheel of torque limit tau needs |h_i| / tau seconds to store its share h_i (by hand:
    R_d^T L with axes "xyz"): with the capture predicted at t_c and the run ending at T, a
    max_torque 10 % below |h_i| / (T - t_c) warns, naming the key and that wheel; 10 % above
    does not."""
    setup = _setup(_with_wheels(""))
    pred = predict_capture(setup)
    assert pred is not None and pred.capture_time is not None
    left = setup.scenario.duration - pred.capture_time
    assert left > 0.0
    R_d = to_rotation(np.asarray(setup.scenario.reference.base_attitude, dtype=float))
    expected = np.abs(R_d.T @ _system_momentum(setup))
    i = int(np.argmax(expected))
    rate = float(expected[i]) / left
    (line,) = _check_warnings(_with_wheels(f"max_torque = {0.9 * rate}\n"))
    assert "robot.satellite.wheels.max_torque" in line and f"wheel {i} " in line
    assert "\n" not in line
    assert _check_warnings(_with_wheels(f"max_torque = {1.1 * rate}\n")) == []
