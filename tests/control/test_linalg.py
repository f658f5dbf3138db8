"""Pseudo-inverses of the kinematic law (ffsm_pin.control.linalg): the plain right inverse of
Eqs. (25)/(36) and its damped least-squares version near rank loss (docs/model.md section 7)."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control.linalg import damped_row_pinv, row_pinv

THRESHOLD = 0.05  # the default SingularityPolicy threshold


def with_singular_values(rng, singular_values, n_cols):
    """A random m x n matrix (m = len(singular_values) <= n) with the given singular values."""
    m = len(singular_values)
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n_cols, n_cols)))
    return U @ np.diag(singular_values) @ V[:m]


@pytest.mark.parametrize("shape", [(1, 4), (3, 4), (3, 5), (3, 3), (2, 7)])
def test_row_pinv_equals_numpy_pinv_for_full_row_rank(rng, shape):
    for _ in range(20):
        a = rng.normal(size=shape)
        p = row_pinv(a)
        np.testing.assert_allclose(p, np.linalg.pinv(a), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(a @ p, np.eye(shape[0]), atol=1e-12)  # right inverse


@pytest.mark.parametrize("n_cols", [3, 4, 5])
def test_damped_equals_undamped_above_threshold(rng, n_cols):
    for _ in range(30):
        sv = np.sort(rng.uniform(THRESHOLD * 1.001, 3.0, 3))[::-1]
        a = with_singular_values(rng, sv, n_cols)
        inv = damped_row_pinv(a, THRESHOLD)
        assert inv.damping == 0.0
        assert inv.sigma_min == pytest.approx(sv[-1], rel=1e-10)
        # cond(A A^T) <= (3 / 0.05)^2 = 3600: agreement to ~1e-12 relative
        np.testing.assert_allclose(inv.pinv, row_pinv(a), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(inv.pinv, np.linalg.pinv(a), rtol=1e-9, atol=1e-11)


@pytest.mark.parametrize("n_cols", [3, 4, 5])
def test_damped_gain_bounded_below_threshold(rng, n_cols):
    for smallest in (0.049, 0.02, 1e-3, 1e-8, 0.0):
        a = with_singular_values(rng, np.array([2.0, 0.7, smallest]), n_cols)
        inv = damped_row_pinv(a, THRESHOLD)
        assert inv.sigma_min == pytest.approx(smallest, abs=1e-7)
        assert inv.damping == pytest.approx(THRESHOLD**2 - inv.sigma_min**2, rel=1e-12)
        gain = np.linalg.norm(inv.pinv, 2)
        # singular values of A^T (A A^T + l^2)^-1 are s / (s^2 + l^2) = s / (s^2 + thr^2 -
        # s_min^2) <= 1 / thr for every s >= s_min: at most 1 / thr (equality at s = s_min)
        assert gain <= (1 + 1e-9) / THRESHOLD
        # the damped inverse is still the regularised least-squares inverse
        lam2 = inv.damping
        expected = a.T @ np.linalg.inv(a @ a.T + lam2 * np.eye(3))
        np.testing.assert_allclose(inv.pinv, expected, rtol=1e-9, atol=1e-12)
        # it acts like the exact inverse on the well-conditioned directions
        U, _, _ = np.linalg.svd(a)
        np.testing.assert_allclose(a @ inv.pinv @ U[:, 0], U[:, 0], atol=1e-3)


def test_undamped_gain_is_unbounded_where_the_damped_one_is_not(rng):
    """The damping matters: without it the gain is 1 / sigma_min."""
    a = with_singular_values(rng, np.array([1.0, 0.5, 1e-6]), 4)
    assert np.linalg.norm(row_pinv(a), 2) == pytest.approx(1e6, rel=1e-4)
    assert np.linalg.norm(damped_row_pinv(a, THRESHOLD).pinv, 2) <= 1 / THRESHOLD * (1 + 1e-9)


def test_continuous_where_damping_starts(rng):
    """Approaching sigma_min = threshold from both sides gives the same inverse."""
    U, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    V, _ = np.linalg.qr(rng.normal(size=(4, 4)))

    def at(smallest):
        return damped_row_pinv(U @ np.diag([1.5, 0.6, smallest]) @ V[:3], THRESHOLD)

    jumps = []
    for eps in (1e-3, 1e-5, 1e-7):
        above, below = at(THRESHOLD * (1 + eps)), at(THRESHOLD * (1 - eps))
        assert above.damping == 0.0 and below.damping > 0.0
        jumps.append(np.linalg.norm(above.pinv - below.pinv, 2))
    # Above: gains 1/s_i. Below: s_i / (s_i^2 + lambda^2), lambda^2 = thr^2 - s_min^2 ~ 2 eps
    # thr^2. The smallest direction changes by O(eps^2 / thr) (value and slope match at the
    # threshold), the others by lambda^2 / s_i^3: the jump is O(eps), bounded below with 50 %
    # margin, and shrinks a hundredfold per hundredfold smaller eps.
    for eps, jump in zip((1e-3, 1e-5, 1e-7), jumps, strict=True):
        lam2 = 2 * eps * THRESHOLD**2
        assert jump <= 1.5 * (lam2 * (1 / 0.6**3 + 1 / 1.5**3) + 2 * eps**2 / THRESHOLD)
    assert jumps[1] < jumps[0] / 50 and jumps[2] < jumps[1] / 50


def test_row_pinv_is_complex_step_safe(rng):
    """row_pinv uses the plain transpose, so f(A + i h dA).imag / h is its derivative."""
    a = rng.normal(size=(3, 4))
    da = rng.normal(size=(3, 4))
    h = 1e-30
    cs = row_pinv(a + 1j * h * da).imag / h
    hr = 1e-6  # central difference, error ~ hr^2 ~ 1e-12 relative
    fd = (row_pinv(a + hr * da) - row_pinv(a - hr * da)) / (2 * hr)
    np.testing.assert_allclose(cs, fd, rtol=1e-7, atol=1e-9)
    # above the threshold the damped version is the same analytic function
    inv = damped_row_pinv(a + 1j * h * da, 1e-3)
    assert inv.damping == 0.0
    np.testing.assert_allclose(inv.pinv.imag / h, fd, rtol=1e-7, atol=1e-9)
