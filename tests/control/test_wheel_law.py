"""lu-jia with the reaction wheels after a capture (issue 40, ``[controller.params] wheels =
"after-capture"``; ``ffsm_pin/control/wheel_law.py``, docs/capture.md): the torque against a
hand computation, the estimate of the robot's own momentum moved by what the wheels store, the
run before the grasp unchanged, both backends alike, bad input."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude.mrp import to_rotation
from ffsm_pin.control.interface import Measurement
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.errors import FfsmError
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.setup import prepare

WHEELS = "\n[robot.satellite.wheels]\ninertia = 0.05\n{limits}\n[controller.params]\n{params}\n"


def _scenario(params: str = 'wheels = "after-capture"', limits: str = "", duration=3.3):
    text = builtin_path("capture").read_text() + WHEELS.format(limits=limits, params=params)
    return dataclasses.replace(scenario_from_toml(text), duration=duration)


def _setup(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return prepare(scenario)


def _meas(setup, rng) -> Measurement:
    """The initial measurement with the bus turned and turning (a state after a grasp)."""
    meas = setup.controller.context.initial
    w = np.array(meas.w, dtype=float)
    w[:3] = 0.01 * rng.standard_normal(3)
    q_b = np.asarray(meas.q_b, dtype=float) + 0.01 * rng.standard_normal(3)
    return meas._replace(q_b=q_b, w=w)


@pytest.mark.parametrize("limits", ["", "max_torque = 1e-4"])
def test_the_torque_and_the_momentum_it_stores_by_hand(limits):
    """After the grasp: tau_w = A^+ I_b (omega^2 phi + 2 omega w_b) with I_b = R^T H_bb(theta_b-hat)
    R, phi the bus's rotation vector from the reference and omega the largest beta_b (by
    hand, 1e-12 relative); A_0-hat (theta_b-hat's head) moves by -R A dh, dh the torque the
    wheels' limits let through times dt; before the grasp zero torque and no change."""
    setup = _setup(_scenario(limits=limits))
    ctx = setup.controller.context
    ctrl = LuJiaController(ctx, backend="numpy")
    meas = _meas(setup, np.random.default_rng(3))
    theta_b = ctrl.law.theta_b.copy()
    assert not ctrl.wheel_torque(meas).any()
    assert np.array_equal(ctrl.law.theta_b, theta_b)
    ctrl._wheels.start()  # (what on_capture does)
    tau = ctrl.wheel_torque(meas)
    wheels = setup.scenario.robot.wheels
    R = to_rotation(np.asarray(meas.q_b))
    phi = pin.log3(to_rotation(np.asarray(ctx.base_attitude_reference)).T @ R)
    w_b = R.T @ meas.w[:3]
    H_bb = ctx.model.momentum_matrices(theta_b, meas.q_b, meas.q_m)[0]
    omega = max(setup.scenario.performance.funnel_b.beta)
    expected = np.linalg.pinv(wheels.axes) @ (R.T @ H_bb @ R) @ (omega**2 * phi + 2 * omega * w_b)
    assert np.abs(tau - expected).max() < 1e-12 * np.abs(expected).max()
    applied = np.clip(expected, -wheels.max_torque, wheels.max_torque)
    if limits:
        assert (np.abs(applied) < np.abs(expected)).any()  # (the limit cuts)
    shift = theta_b[:3] - ctrl.law.theta_b[:3]
    want = R @ wheels.axes @ (applied * ctx.dt)
    assert np.abs(shift - want).max() < 1e-12 * np.abs(want).max()
    assert np.array_equal(ctrl.law.theta_b[3:], theta_b[3:])


def test_a_run_is_unchanged_before_the_grasp_and_keeps_the_momentum():
    """The capture case with the wheels and the law's wheel output: no torque before the grasp
    (q, v, u_m bit for bit the run whose wheels nobody commands), torques after it, the whole
    system's L (robot, box, wheels) kept to 1e-12; numpy and compiled periods alike."""
    runs = {
        (params, backend): simulate(_setup(_scenario(params=f'{params}\nbackend = "{backend}"')))
        for params, backend in (
            ('wheels = "after-capture"', "numba"),
            ('wheels = "after-capture"', "numpy"),
            ('wheels = "none"', "numba"),
        )
    }  # fmt: skip
    wheeled = runs['wheels = "after-capture"', "numba"]
    plain = runs['wheels = "none"', "numba"]
    summary = wheeled.summary()
    t, tau = wheeled["t"], wheeled["wheel_torque"]
    before = t < summary["capture_time"]
    assert summary["captured"] and not tau[before].any()
    assert np.abs(tau[~before]).max() > 0
    for key in ("q", "v", "u_m"):
        np.testing.assert_array_equal(wheeled[key][before], plain[key][before], err_msg=key)
    L = wheeled["L"]
    assert np.abs(L - L[0]).max() < 1e-12 * np.abs(L).max()
    reference = runs['wheels = "after-capture"', "numpy"]
    for key in ("u_m", "wheel_torque"):
        scale = np.abs(reference[key]).max()
        # (measured 2e-14 relative over 3.3 s; the compiled period orders its sums otherwise)
        np.testing.assert_allclose(wheeled[key], reference[key], rtol=0, atol=1e-11 * scale)


@pytest.mark.parametrize(
    ("params", "wheels", "words"),
    [
        ('wheels = "always"', True, ["controller.params.wheels", "'after-capture'"]),
        ('wheels = "after-capture"', False, ["needs [robot.satellite.wheels]"]),
    ],
)
def test_bad_wheel_modes_are_one_line(params, wheels, words):
    text = builtin_path("capture").read_text()
    if wheels:
        text += "\n[robot.satellite.wheels]\ninertia = 0.05\n"
    text += f"\n[controller.params]\n{params}\n"
    with pytest.raises(FfsmError) as err:
        _setup(scenario_from_toml(text))
    message = str(err.value)
    assert "\n" not in message and all(w in message for w in words)
