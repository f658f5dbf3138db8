"""Derived default gains and the discrete-time conditions on the gains (docs/gains.md)."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control.funnel import Funnel, FunnelParams
from ffsm_pin.control.gains import (
    ATTITUDE_RATE_SQUARED,
    STEP_MARGIN,
    Gains,
    derived_gain,
    loop_rate,
    step_problems,
)

PAPER_B = FunnelParams((1.0,), (0.03,), (0.22,), (0.8,))
PAPER_Z = FunnelParams((1.0, 1.0, 0.2), (0.08, 0.08, 0.05), (0.22,) * 3, (0.8,) * 3)
SPATIAL_Z = FunnelParams((0.06,) * 3, (0.01,) * 3, (0.2,) * 3, (0.8,) * 3)


@pytest.mark.parametrize("e0", [0.3, -0.3])
@pytest.mark.parametrize("sigma", [0.3, 0.8, 1.0])
def test_loop_rate_is_the_transformations_slope_at_zero(e0, sigma):
    """g = k (1 + 1/sigma)^2 / rho^2 is k Phi(0)^2 with Eq. (22)'s Phi from the funnel code
    (both sides of an asymmetric funnel), and psi ~ Phi(0) e near e = 0."""
    params = FunnelParams((0.5,), (0.02,), (0.3,), (sigma,))
    funnel = Funnel(params, np.array([e0]))
    t = 40.0  # rho ~ rho_inf
    ev = funnel.evaluate(t, np.array([1e-9]))
    rho = funnel.rho(t)
    np.testing.assert_allclose(loop_rate(1.0, params, rho), ev.Phi**2, rtol=1e-6)
    np.testing.assert_allclose(ev.psi, ev.Phi * 1e-9, rtol=1e-6)


def test_derived_gain_closed_form_and_the_papers_value():
    """k = max_i beta_i rho0_i^2 / (1 + 1/sigma_i)^2 while the step cap does not bind; on
    the paper's funnels that is within 9 % of the paper's 0.04 (Section 4)."""
    want = 0.22 * 1.0**2 / (1 + 1 / 0.8) ** 2
    assert derived_gain(PAPER_B, 1e-3) == pytest.approx(want, rel=1e-12)
    assert derived_gain(PAPER_Z, 1e-3) == pytest.approx(want, rel=1e-12)
    assert abs(want / 0.04 - 1) < 0.09
    # at t = 0 every component's loop is at least as fast as its funnel's decay, the
    # binding one (x, y: rho_0 = 1) exactly as fast
    ratio = loop_rate(want, PAPER_Z, PAPER_Z.rho0) / np.array(PAPER_Z.beta)
    np.testing.assert_allclose(np.min(ratio), 1.0)


def test_derived_gain_is_capped_by_the_step_condition():
    """A funnel that closes far (rho_inf << rho_0) at a long dt: the cap g(rho_inf) dt =
    STEP_MARGIN binds, so the derived gain satisfies every condition."""
    tight = FunnelParams((1.0,), (0.001,), (0.5,), (0.8,))
    dt = 0.01
    k = derived_gain(tight, dt)
    np.testing.assert_allclose(loop_rate(k, tight, tight.rhoinf) * dt, STEP_MARGIN)
    assert k < 0.5 / (1 + 1 / 0.8) ** 2  # below the start rule
    assert step_problems(Gains(k_z=k, k_b=k), tight, tight, dt, 1) == []


def _iterate(g_dt: float, steps: int = 200) -> float:
    """|e| after explicit steps of de/dt = -k Phi psi with g dt = k Phi(0)^2 dt, inside a
    closed funnel (rho = 1, sigma = 1), from e = 0.01: the loop the condition is about."""
    params = FunnelParams((2.0,), (1.0,), (1.0,), (1.0,))
    funnel = Funnel(params, np.array([0.01]))
    t = 1e3  # closed: rho = 1
    k = g_dt / float(loop_rate(1.0, params, [1.0])[0])  # dt = 1
    e = np.array([0.01])
    for _ in range(steps):
        if not funnel.inside(t, e):
            return np.inf
        ev = funnel.evaluate(t, e)
        e = e - k * ev.Phi * ev.psi
    return float(abs(e[0]))


def test_step_condition_separates_convergence_from_divergence():
    """The condition the warning states, g dt < 2, is where the explicit iteration of the
    kinematic law stops converging (on the transformation itself, not its linearisation)."""
    assert _iterate(1.9) < 1e-4
    assert _iterate(0.5) < 1e-12
    assert _iterate(2.1) > 0.01  # grows or leaves the funnel


def test_problems_name_the_gain_and_a_value_that_satisfies_it():
    # the paper's k_z on the shipped spatial funnels at dt = 2 ms: g dt = 4.05
    found = step_problems(Gains(), PAPER_B, SPATIAL_Z, 2e-3, 1)
    assert [p.gain for p in found] == ["k_z"]
    g_dt = 0.04 * (1 + 1 / 0.8) ** 2 / 0.01**2 * 2e-3
    assert f"g dt = {g_dt:.3g}" in found[0].text and "k_z = " in found[0].text
    fixed = Gains(k_z=found[0].suggested)
    assert step_problems(fixed, PAPER_B, SPATIAL_Z, 2e-3, 1) == []
    # k_d's explicit step; the attitude law only when the scheme has it
    assert [p.gain for p in step_problems(Gains(k_d=2500.0), PAPER_B, PAPER_Z, 1e-3, 1)] == ["k_d"]
    tiny_b = FunnelParams((1.0,), (1e-4,), (0.2,), (0.8,))
    assert [p.gain for p in step_problems(Gains(), tiny_b, PAPER_Z, 1e-3, 1)] == ["k_b"]
    assert step_problems(Gains(), tiny_b, PAPER_Z, 1e-3, 1, attitude=False) == []


def test_mrp_base_factor():
    """The MRP base attitude moves at a quarter of the angular rate, met twice by Eq. (25):
    the same k on a spatial base is 16 times slower (derived gain 16 times larger)."""
    assert ATTITUDE_RATE_SQUARED[3] == 1 / 16
    assert derived_gain(PAPER_B, 1e-3, 1 / 16) == pytest.approx(16 * derived_gain(PAPER_B, 1e-3))
