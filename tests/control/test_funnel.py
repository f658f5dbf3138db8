"""Prescribed-performance funnels (ffsm_pin.control.funnel) against Eqs. (16)-(24) of Lu & Jia
(2019): the performance function, the error transformation R, its derivative Phi, the side
chosen by the sign of e(0), the refusal outside, and the bound ||s||^2 <= ||psi||^2 / 4."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffsm_pin.control.funnel import Funnel, FunnelExit, FunnelParams, IdentityFunnel
from ffsm_pin.errors import ParameterError

# The paper's end-effector funnel (Section 4) and a second one with sigma = 1 and distinct rates.
PAPER_Z = FunnelParams((1.0, 1.0, 0.2), (0.08, 0.08, 0.05), (0.22,) * 3, (0.8,) * 3)
OTHER = FunnelParams((2.0, 0.5, 0.3), (0.1, 0.2, 0.01), (1.5, 0.05, 0.7), (1.0, 0.3, 0.55))
PARAMS = [PAPER_Z, OTHER]


def paper_R(s, sigma, positive):
    """Eq. (21), written out independently of the package: the two branches by the side."""
    if positive:
        return np.log((sigma + s) / (sigma - sigma * s))
    return np.log((sigma + sigma * s) / (sigma - s))


def inside_point(funnel: Funnel, t: float, fraction) -> np.ndarray:
    """An error at ``fraction`` in [0, 1] of the way from the lower to the upper bound."""
    lo, hi = funnel.bounds(t)
    return lo + np.asarray(fraction) * (hi - lo)


# ----------------------------------------------------------------------------- rho (Eqs. 18-19)
@pytest.mark.parametrize("params", PARAMS)
def test_rho_starts_at_rho0_and_tends_to_rhoinf(params):
    funnel = Funnel(params, np.ones(params.size))
    for rho_of in (params.rho, funnel.rho):
        np.testing.assert_allclose(rho_of(0.0), params.rho0, rtol=1e-15)
        # after 60 time constants of the slowest component exp(-beta t) < 1e-26
        t_end = 60.0 / min(params.beta)
        np.testing.assert_allclose(rho_of(t_end), params.rhoinf, rtol=1e-14)
        ts = np.linspace(0.0, 10.0, 201)
        rhos = np.array([rho_of(t) for t in ts])
        assert np.all(np.diff(rhos, axis=0) < 0)  # strictly decreasing (Section 3.1)
        assert np.all(rhos > np.array(params.rhoinf))


@pytest.mark.parametrize("params", PARAMS)
def test_rho_dot_is_the_derivative_of_rho(params):
    funnel = Funnel(params, np.ones(params.size))
    h = 1e-5  # central difference: error ~ h^2 beta^3 rho0 / 6 < 1e-9, rounding ~ 1e-16 / h
    for t in (0.0, 0.3, 2.0, 11.0):
        fd = (params.rho(t + h) - params.rho(t - h)) / (2 * h)
        np.testing.assert_allclose(params.rho_dot(t), fd, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(funnel.rho_dot(t), fd, rtol=1e-8, atol=1e-12)
        e = inside_point(funnel, t, 0.5)
        np.testing.assert_allclose(funnel.evaluate(t, e).rho_dot, fd, rtol=1e-8, atol=1e-12)


# ------------------------------------------------------------------- psi, Phi (Eqs. 20-22)
@pytest.mark.parametrize("params", PARAMS)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_psi_is_eq_21_on_the_side_of_e0(params, sign):
    funnel = Funnel(params, sign * np.full(params.size, 0.01))
    sigma = np.array(params.sigma)
    for t in (0.0, 1.7):
        for frac in (0.05, 0.3, 0.5, 0.77, 0.99):
            e = inside_point(funnel, t, frac)
            ev = funnel.evaluate(t, e)
            s = e / params.rho(t)
            np.testing.assert_allclose(ev.s, s, rtol=1e-15)
            np.testing.assert_allclose(ev.psi, paper_R(s, sigma, sign > 0), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("params", PARAMS)
def test_side_is_chosen_by_the_sign_of_e0(params):
    """Eq. (16)/(17): e(0) >= 0 -> (-sigma rho, rho); e(0) < 0 -> (-rho, sigma rho)."""
    rho0, sigma = np.array(params.rho0), np.array(params.sigma)
    e0 = np.array([0.0, -1e-9, 0.3])[: params.size]  # e(0) = 0 counts as the positive side
    funnel = Funnel(params, e0)
    lo, hi = funnel.bounds(0.0)
    positive = e0 >= 0
    np.testing.assert_allclose(lo, np.where(positive, -sigma * rho0, -rho0))
    np.testing.assert_allclose(hi, np.where(positive, rho0, sigma * rho0))
    # a point between sigma rho and rho is inside on one side only (sigma < 1 components)
    for k in np.flatnonzero(sigma < 1):
        probe = np.zeros(params.size)
        probe[k] = 0.5 * (1 + sigma[k]) * rho0[k]  # above sigma rho, below rho
        pos = Funnel(params, np.abs(e0) + 0.1)
        neg = Funnel(params, -np.abs(e0) - 0.1)
        assert pos.inside(0.0, probe) and not neg.inside(0.0, probe)
        assert neg.inside(0.0, -probe) and not pos.inside(0.0, -probe)


@pytest.mark.parametrize("params", PARAMS)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_psi_zero_iff_s_zero_and_monotone(params, sign):
    funnel = Funnel(params, sign * np.ones(params.size))
    t = 0.8
    zero = funnel.evaluate(t, np.zeros(params.size))
    np.testing.assert_array_equal(zero.psi, 0.0)
    lo, hi = funnel.bounds(t)
    # a fine grid across the whole open interval, s = 0 excluded
    fr = np.linspace(1e-6, 1 - 1e-6, 2001)
    grid = lo[None, :] + fr[:, None] * (hi - lo)[None, :]
    grid = grid[np.all(grid != 0, axis=1)]
    psi = np.array([funnel.evaluate(t, e).psi for e in grid])
    assert np.all(psi != 0)
    np.testing.assert_array_equal(np.sign(psi), np.sign(grid))  # R maps 0 to 0 only
    assert np.all(np.diff(psi, axis=0) > 0)  # strictly increasing in s
    # and R maps onto (-inf, inf): psi is large near both bounds
    assert np.all(psi[0] < -5) and np.all(psi[-1] > 5)


@pytest.mark.parametrize("params", PARAMS)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_Phi_is_dpsi_de(params, sign):
    """Phi = dR/ds / rho (Eq. 22) = d psi / d e at fixed t: compare with a central difference."""
    funnel = Funnel(params, sign * np.ones(params.size))
    for t in (0.0, 2.5):
        rho = params.rho(t)
        for frac in (0.1, 0.5, 0.9):
            e = inside_point(funnel, t, frac)
            h = 1e-6 * rho  # relative step in s; error ~ (h/rho)^2 R''' ~ 1e-10 near the bounds
            fd = (funnel.evaluate(t, e + h).psi - funnel.evaluate(t, e - h).psi) / (2 * h)
            np.testing.assert_allclose(funnel.evaluate(t, e).Phi, fd, rtol=1e-7)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_complex_step_derivative_of_psi_along_a_trajectory(sign):
    """d/dt psi(t, e(t)) by complex step equals a central difference and Eq. (22),
    Phi (de/dt - drho/dt s)."""
    params = OTHER
    funnel = Funnel(params, sign * np.ones(3))
    sigma = np.array(params.sigma)

    def e_of(t):  # a smooth error that stays well inside the funnel (|s| <= 0.45 sigma)
        shape = 0.3 * np.cos(np.array([0.7, 1.3, 2.1]) * t + np.array([0.0, 0.5, 1.0]))
        return sign * sigma * (0.15 + shape) * funnel.rho(t)

    def de_of(t):
        w = np.array([0.7, 1.3, 2.1])
        shape = 0.3 * np.cos(w * t + np.array([0.0, 0.5, 1.0]))
        dshape = -0.3 * w * np.sin(w * t + np.array([0.0, 0.5, 1.0]))
        return sign * sigma * ((0.15 + shape) * funnel.rho_dot(t) + dshape * funnel.rho(t))

    hc = 1e-30  # complex step: exact to rounding for an analytic function
    hr = 1e-5  # central difference: error ~ hr^2 |psi'''| ~ 1e-9
    for t in (0.0 + 0.2, 1.0, 3.3, 7.0):
        tc = t + 1j * hc
        cs = funnel.evaluate(tc, e_of(tc)).psi.imag / hc
        fd = funnel.evaluate(t + hr, e_of(t + hr)).psi - funnel.evaluate(t - hr, e_of(t - hr)).psi
        fd /= 2 * hr
        np.testing.assert_allclose(cs, fd, rtol=1e-7, atol=1e-9)
        ev = funnel.evaluate(t, e_of(t))
        eq22 = ev.Phi * (de_of(t) - ev.rho_dot * ev.s)
        np.testing.assert_allclose(cs, eq22, rtol=1e-12, atol=1e-14)


# ---------------------------------------------------------------------- outside the funnel
@pytest.mark.parametrize("params", PARAMS)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_evaluate_refuses_outside_and_inside_agrees(params, sign, rng):
    funnel = Funnel(params, sign * np.ones(params.size))
    n_in = n_out = 0
    for _ in range(400):
        t = rng.uniform(0.0, 15.0)
        lo, hi = funnel.bounds(t)
        e = inside_point(funnel, t, rng.uniform(-0.25, 1.25, params.size))
        inside = funnel.inside(t, e)
        assert inside == bool(np.all((e > lo) & (e < hi)))
        assert inside == bool(np.all(funnel.margin(t, e) > 0))
        if inside:
            n_in += 1
            ev = funnel.evaluate(t, e)
            assert np.all(np.isfinite(ev.psi)) and np.all(ev.Phi > 0)
        else:
            n_out += 1
            with pytest.raises(FunnelExit) as info:
                funnel.evaluate(t, e)
            k = info.value.index
            assert not lo[k] < e[k] < hi[k]
            assert info.value.value == pytest.approx(e[k])
            assert (info.value.lower, info.value.upper) == pytest.approx((lo[k], hi[k]))
    assert n_in > 50 and n_out > 50  # both branches exercised
    # exactly on a bound is outside (strict inequalities of Eq. 16/17)
    lo, hi = funnel.bounds(1.0)
    for edge in (lo, hi):
        assert not funnel.inside(1.0, edge)
        with pytest.raises(FunnelExit):
            funnel.evaluate(1.0, edge)


# --------------------------------------------------------------------------- Eqs. (23)-(24)
@st.composite
def funnel_and_point(draw):
    n = draw(st.integers(1, 4))
    floats = st.floats
    rho0 = np.array([draw(floats(0.05, 5.0)) for _ in range(n)])
    ratio = np.array([draw(floats(0.01, 0.95)) for _ in range(n)])
    beta = tuple(draw(floats(0.01, 3.0)) for _ in range(n))
    sigma = tuple(draw(floats(0.05, 1.0)) for _ in range(n))
    params = FunnelParams(tuple(rho0), tuple(rho0 * ratio), beta, sigma)
    e0 = np.array([draw(floats(-1.0, 1.0)) for _ in range(n)])
    frac = np.array([draw(floats(1e-6, 1 - 1e-6)) for _ in range(n)])
    t = draw(floats(0.0, 30.0))
    return params, e0, frac, t


@settings(max_examples=300, deadline=None, derandomize=True)
@given(funnel_and_point())
def test_s_norm_bounded_by_psi_norm(case):
    """||s||^2 <= ||psi||^2 / 4 (Eqs. 23-24): |R(s)| >= 2 |s| because R(0) = 0 and
    R'(s) = 1/(sigma + s) + 1/(1 - s) >= 4 / (1 + sigma) >= 2 (positive side; mirrored)."""
    params, e0, frac, t = case
    funnel = Funnel(params, e0)
    ev = funnel.evaluate(t, inside_point(funnel, t, frac))
    # the bound is tight at s -> 0 with sigma = 1 (R = 2 artanh s): allow rounding of the log
    assert np.sum(ev.s**2) <= np.sum(ev.psi**2) / 4 * (1 + 1e-12) + 1e-300
    assert np.all(np.abs(ev.psi) >= 2 * np.abs(ev.s) * (1 - 1e-12))


# -------------------------------------------------------------------------- IdentityFunnel
def test_identity_funnel_is_case_2():
    """Case 2 of Section 4: psi = e, Phi = 1, drho/dt = 0; never refuses, still reports."""
    funnel = IdentityFunnel(PAPER_Z, np.array([0.2, -0.1, 0.05]))
    for t, e in ((0.0, np.array([0.1, -0.2, 0.01])), (3.0, np.array([5.0, -7.0, 2.0]))):
        ev = funnel.evaluate(t, e)
        np.testing.assert_array_equal(ev.psi, e)
        np.testing.assert_array_equal(ev.s, e)
        np.testing.assert_array_equal(ev.Phi, 1.0)
        np.testing.assert_array_equal(ev.rho_dot, 0.0)
    assert funnel.inside(0.0, np.array([0.1, -0.2, 0.01]))
    assert not funnel.inside(3.0, np.array([5.0, -7.0, 2.0]))  # reported, not refused
    # complex step passes straight through: d psi / dt = de/dt
    ev = funnel.evaluate(1.0 + 1e-30j, np.array([0.1, 0.2, 0.3]) + 1e-30j * np.array([1, 2, 3]))
    np.testing.assert_array_equal(ev.psi.imag / 1e-30, [1.0, 2.0, 3.0])


# -------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(rho0=(1.0,), rhoinf=(1.0,), beta=(0.2,), sigma=(0.8,)), "rhoinf"),
        (dict(rho0=(1.0,), rhoinf=(1.5,), beta=(0.2,), sigma=(0.8,)), "rhoinf"),
        (dict(rho0=(1.0,), rhoinf=(0.0,), beta=(0.2,), sigma=(0.8,)), "rhoinf"),
        (dict(rho0=(1.0,), rhoinf=(-0.1,), beta=(0.2,), sigma=(0.8,)), "rhoinf"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(0.2,), sigma=(0.0,)), "sigma"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(0.2,), sigma=(1.0001,)), "sigma"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(0.2,), sigma=(-0.5,)), "sigma"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(-0.2,), sigma=(0.8,)), "beta"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(0.0,), sigma=(0.8,)), "beta"),
        (dict(rho0=(1.0, 1.0), rhoinf=(0.1,), beta=(0.2,), sigma=(0.8,)), "length"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(0.2, 0.2), sigma=(0.8,)), "length"),
        (dict(rho0=(np.inf,), rhoinf=(0.1,), beta=(0.2,), sigma=(0.8,)), "finite"),
        (dict(rho0=(1.0,), rhoinf=(0.1,), beta=(np.nan,), sigma=(0.8,)), "finite"),
    ],
)
def test_funnel_params_validation(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        FunnelParams(**kwargs)


def test_funnel_params_accept_sigma_one_and_are_frozen():
    p = FunnelParams((1.0,), (0.1,), (0.2,), (1.0,))  # sigma = 1 is allowed (0 < sigma <= 1)
    assert p.size == 1
    with pytest.raises(AttributeError):
        p.rho0 = (2.0,)


def test_funnel_rejects_initial_error_of_wrong_size():
    with pytest.raises(ParameterError, match="3 components"):
        Funnel(PAPER_Z, np.zeros(2))
