"""Closed-form updates of the adaptation laws (ffsm_pin.control.adaptation), each against its ODE:
Eq. (28) (exact zero-order hold), Eq. (42)/(43) (backward Euler), Eq. (50) (exact for a held
input) and Eq. (51) (linearly implicit)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from ffsm_pin.control.adaptation import (
    regressor_filter_step,
    theta_b_step,
    theta_d_increment,
    theta_z_step,
)

N_B = 16  # theta_b of the paper robot (Table 2)
N_Z = 7  # theta_z of the paper robot; the controller passes the two position rows of Y_z
N_D = 15


def spd(rng, n, lo=1.0, hi=40.0):
    """A random symmetric positive definite matrix with eigenvalues in [lo, hi]."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ np.diag(rng.uniform(lo, hi, n)) @ Q.T


# ---------------------------------------------------------------------------- Eq. (28)
@pytest.mark.parametrize("rows", [1, 2])
@pytest.mark.parametrize("gdt", [1e-4, 1e-2, 1.0, 1e3])  # gamma_1 dt |Y|^2 from tiny to stiff
def test_theta_b_step_is_the_matrix_exponential(rng, rows, gdt):
    """dtheta/dt = -Gamma_1 Y^T Y theta, Y held: theta(dt) = expm(-Gamma_1 dt Y^T Y) theta(0)."""
    for _ in range(10):
        Y = rng.normal(size=(rows, N_B)) * rng.uniform(0.1, 30.0)
        theta = rng.normal(size=N_B) * 10
        gamma_1 = 10.0
        dt = gdt / (gamma_1 * np.sum(Y**2))
        exact = scipy.linalg.expm(-gamma_1 * dt * Y.T @ Y) @ theta
        got = theta_b_step(theta, Y, gamma_1, dt)
        np.testing.assert_allclose(got, exact, rtol=1e-10, atol=1e-10 * np.linalg.norm(theta))


def test_theta_b_step_zero_regressor_is_identity(rng):
    theta = rng.normal(size=N_B)
    np.testing.assert_array_equal(theta_b_step(theta, np.zeros((1, N_B)), 10.0, 1e-3), theta)


def test_theta_b_step_never_increases_the_norm(rng):
    """A contraction for any step size: explicit Euler is not (unstable for gdt|Y|^2 > 2)."""
    gamma_1 = 10.0
    theta = rng.normal(size=N_B) * 10
    norms = [np.linalg.norm(theta)]
    for _ in range(2000):
        Y = rng.normal(size=(1, N_B)) * 10 ** rng.uniform(-2, 2)
        dt = 10 ** rng.uniform(-5, 0)
        theta = theta_b_step(theta, Y, gamma_1, dt)
        norms.append(np.linalg.norm(theta))
    assert np.all(np.diff(norms) <= 1e-12 * norms[0])
    # and the component of theta along a regressor held for long is removed (Eq. 15)
    Y = rng.normal(size=(1, N_B))
    out = theta_b_step(theta, Y, gamma_1, 1e3)
    assert abs((Y @ out)[0]) <= 1e-12 * np.linalg.norm(Y) * np.linalg.norm(theta)


def test_theta_b_step_truth_in_null_space_error_contracts(rng):
    """Eq. (29): with Y theta_b = 0 for the truth, theta~ = theta - theta-hat obeys the same
    law, so the closed form contracts |theta~| too."""
    truth = rng.normal(size=N_B)
    est = truth + rng.normal(size=N_B)
    for _ in range(300):
        Y = rng.normal(size=(1, N_B))
        Y -= (Y @ truth) / (truth @ truth) * truth  # Y_b theta_b = 0 (Eq. 15)
        new = theta_b_step(est, Y, 10.0, 10 ** rng.uniform(-4, 0))
        assert np.linalg.norm(new - truth) <= np.linalg.norm(est - truth) * (1 + 1e-13)
        est = new


# ---------------------------------------------------------------------------- Eq. (42)-(43)
@pytest.mark.parametrize("gdt", [1e-3, 1e-2, 1.0, 1e6, 1e14])
def test_theta_z_step_is_backward_euler(rng, gdt):
    """theta+ = theta + Gamma_2 dt Y^T (measured - Y theta+) holds (the implicit equation)."""
    for _ in range(10):
        Y = rng.normal(size=(2, N_Z)) * rng.uniform(0.1, 3.0)
        theta = rng.normal(size=N_Z)
        measured = rng.normal(size=2)
        new = theta_z_step(theta, Y, measured, gdt, 1.0)  # gamma_2 dt = gdt
        residual = new - theta - gdt * Y.T @ (measured - Y @ new)
        # the residual is rounding of the (measured - Y theta+) term amplified by gdt; below
        # gdt ~ 1 it is rounding of theta itself
        scale = 1 + np.linalg.norm(theta) + np.linalg.norm(measured)
        assert np.linalg.norm(residual) <= 1e-12 * scale * max(1.0, gdt)
        if gdt >= 1e6:  # stiff limit: the prediction matches the measurement
            np.testing.assert_allclose(Y @ new, measured, atol=1e-5 * scale)


@pytest.mark.parametrize("gdt", [1e-3, 1e-1, 10.0, 1e4, 1e10])
def test_theta_z_error_never_increases(rng, gdt):
    """With measured = Y_z theta_true (Eq. 41), |theta_z-hat - theta_z| is non-increasing
    (Eq. 43) for any gamma_2 dt, also huge: backward Euler is unconditionally stable."""
    truth = rng.normal(size=N_Z) * 2
    est = truth + rng.normal(size=N_Z) * 3
    errors = [np.linalg.norm(est - truth)]
    for _ in range(500):
        Y = rng.normal(size=(2, N_Z)) * 10 ** rng.uniform(-1, 1)
        est = theta_z_step(est, Y, Y @ truth, gdt, 1.0)
        errors.append(np.linalg.norm(est - truth))
    assert np.all(np.isfinite(errors))
    assert np.all(np.diff(errors) <= 1e-12 * errors[0])
    if gdt >= 1e-1:  # persistently exciting random regressors: it actually converges
        assert errors[-1] < 1e-3 * errors[0]


# -------------------------------------------------------------------------------- Eq. (50)
@pytest.mark.parametrize("k_de", [0.3, 5.0, 1e4])
@pytest.mark.parametrize("dt", [1e-3, 0.5])
def test_regressor_filter_step_solves_eq_50_for_held_input(rng, k_de, dt):
    """dY_df/dt + k_de Y_df = Y_dc with Y_dc constant over dt: compare with a tight ODE solve."""
    Y0 = rng.normal(size=(5, N_D))
    Yc = rng.normal(size=(5, N_D)) * 3
    got = regressor_filter_step(Y0, Yc, k_de, dt)
    sol = solve_ivp(
        lambda t, y: Yc.ravel() - k_de * y,
        (0.0, dt),
        Y0.ravel(),
        method="Radau",  # stiff for k_de = 1e4
        rtol=1e-12,
        atol=1e-13,
    )
    np.testing.assert_allclose(got, sol.y[:, -1].reshape(Y0.shape), rtol=1e-8, atol=1e-9)
    # exact for a held input: two half steps equal one step (semigroup property)
    half = regressor_filter_step(regressor_filter_step(Y0, Yc, k_de, dt / 2), Yc, k_de, dt / 2)
    np.testing.assert_allclose(half, got, rtol=1e-12, atol=1e-13)
    # the fixed point Y_dc / k_de is kept
    np.testing.assert_allclose(
        regressor_filter_step(Yc / k_de, Yc, k_de, dt), Yc / k_de, rtol=1e-12
    )


# -------------------------------------------------------------------------------- Eq. (51)
def _theta_d_case(rng):
    nb = 5
    return rng.normal(size=(nb, N_D)) * 2, rng.normal(size=nb), spd(rng, nb)


def test_theta_d_increment_satisfies_its_implicit_equation(rng):
    """dtheta = -c Y_df^T w~+ with w~+ = w~ + M-hat^-1 Y_df dtheta (w~ at the end of the step
    along Eq. 54) and c = Gamma_3 dt."""
    for c in (1e-4, 1e-2, 1.0, 1e3):
        Y, wt, M = _theta_d_case(rng)
        d = theta_d_increment(Y, wt, M, c, 1.0)
        w_end = wt + np.linalg.solve(M, Y @ d)
        np.testing.assert_allclose(d, -c * Y.T @ w_end, rtol=1e-9, atol=1e-12)


def test_theta_d_increment_tends_to_explicit_euler(rng):
    """As Gamma_3 dt -> 0 the step equals -Gamma_3 dt Y_df^T w~ (Eq. 51), relative error
    O(Gamma_3 dt |Y|^2 / lambda_min(M))."""
    Y, wt, M = _theta_d_case(rng)
    gamma_3 = 10.0
    rel = []
    for dt in (1e-3, 1e-4, 1e-5, 1e-6):
        explicit = -gamma_3 * dt * Y.T @ wt
        got = theta_d_increment(Y, wt, M, gamma_3, dt)
        rel.append(np.linalg.norm(got - explicit) / np.linalg.norm(explicit))
    assert rel[-1] < 1e-3
    for a, b in zip(
        rel[:-1], rel[1:], strict=True
    ):  # first order: tenfold smaller per tenfold smaller dt
        assert 7 < a / b < 13


def test_theta_d_increment_bounded_for_huge_gain(rng):
    """As Gamma_3 dt -> infinity the step tends to -Y^T (Y Y^T)^-1 M w~ (finite), where
    explicit Euler would grow without bound.

    The step minimises |dtheta|^2 / (2c) + |w~ + M^-1 Y dtheta|_M^2 / 2 (its stationarity
    condition is the implicit equation): a Tikhonov-regularised least-squares solution, whose
    norm grows monotonically with c towards the minimum-norm solution of Y dtheta = -M w~."""
    Y, wt, M = _theta_d_case(rng)
    limit = -Y.T @ np.linalg.solve(Y @ Y.T, M @ wt)
    norms = []
    for c in 10.0 ** np.arange(-3, 13):
        d = theta_d_increment(Y, wt, M, c, 1.0)
        assert np.all(np.isfinite(d))
        norms.append(np.linalg.norm(d))
    assert np.all(np.diff(norms) >= -1e-9 * norms[-1])
    assert max(norms) <= (1 + 1e-9) * np.linalg.norm(limit)
    np.testing.assert_allclose(theta_d_increment(Y, wt, M, 1e12, 1.0), limit, rtol=1e-6)
    # in the limit w~ at the end of the step vanishes: w~+ = w~ + M^-1 Y dtheta -> 0
    d = theta_d_increment(Y, wt, M, 1e12, 1.0)
    assert np.linalg.norm(wt + np.linalg.solve(M, Y @ d)) < 1e-6 * np.linalg.norm(wt)
