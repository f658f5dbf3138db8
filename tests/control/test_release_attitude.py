"""The paper's law letting the base attitude go mid-run (``CompiledPeriod.release_attitude``,
used by lu-jia's wheels after a capture; docs/capture.md, "The paper's controller with the
wheels"): from the call on, a ``"ppc"`` controller is the scheme ``"no-attitude"``'s
(Eq. 81), on both backends, planar and spatial."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.sim.setup import prepare


def _controller(case: str, scheme: str, backend: str) -> LuJiaController:
    text = builtin_path(case).read_text().replace('scheme = "ppc"', f'scheme = "{scheme}"', 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(scenario_from_toml(text))
    return LuJiaController(setup.controller.context, backend=backend)


def _measurements(ctrl: LuJiaController, rng, periods: int):
    """The initial measurement, then the same with the base turning and the joints moving a
    little more each period (a state the released law has to act on)."""
    meas = ctrl.context.initial
    w0 = np.asarray(meas.w, dtype=float)
    dw = 0.02 * rng.standard_normal(w0.size)
    for k in range(periods):
        yield meas._replace(t=meas.t + k * ctrl.context.dt, w=w0 + (k + 1) * dw)


@pytest.mark.parametrize("backend", ["numpy", "numba"])
@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_a_released_law_is_the_no_attitude_scheme(case, backend):
    """Released before its first period, the "ppc" controller's torques and signals equal
    those of the "no-attitude" controller of the same scenario over three periods (the
    estimates advanced by each), within 1e-12 of their size, on each backend; unreleased, the
    torques differ (the attitude rows act)."""
    released = _controller(case, "ppc", backend)
    kept = _controller(case, "ppc", backend)
    eq81 = _controller(case, "no-attitude", backend)
    released.law.release_attitude()
    rng = np.random.default_rng(7)
    for meas in _measurements(eq81, rng, 3):
        u_r, sig_r = released.step(meas)
        u_k, _ = kept.step(meas)
        u_e, sig_e = eq81.step(meas)
        scale = np.abs(u_e).max()
        assert np.abs(u_r - u_e).max() <= 1e-12 * scale
        for key in ("w_mc", "theta_d_hat", "theta_b_hat", "w_hat"):
            a, b = np.asarray(sig_r[key]), np.asarray(sig_e[key])
            assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1.0), key
        assert np.abs(u_k - u_e).max() > 1e-6 * scale


def test_a_release_survives_a_later_switch_to_the_compiled_period():
    """Released on the numpy reference, then switched to the compiled period (whose kernels
    are made then): the compiled period runs Eq. (81) too, as the "no-attitude" controller;
    the controller says what its sigma_min measured (J_m-hat U-hat, then J_m-hat)."""
    released = _controller("spatial", "ppc", "numpy")
    eq81 = _controller("spatial", "no-attitude", "numba")
    assert released.sigma_measure == "J_m-hat U-hat"
    released.law.release_attitude()
    released.law.backend = "numba"
    meas = next(_measurements(eq81, np.random.default_rng(5), 1))
    u_r, _ = released.step(meas)
    u_e, _ = eq81.step(meas)
    assert np.abs(u_r - u_e).max() <= 1e-12 * np.abs(u_e).max()
    assert released.sigma_measure.startswith("J_m-hat U-hat, then J_m-hat")
    assert eq81.sigma_measure == "J_m-hat"
