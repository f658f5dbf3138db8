"""The compiled products and small solves by loops (``ffsm_pin/_array_kernels.py``) against
numpy and LAPACK: the same values to rounding, the same errors, and exact complex-step
derivatives where the control periods differentiate through them."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin._array_kernels import (
    gram,
    mm,
    mv,
    spd_solve,
    symmetric_solve_transposed,
)

EPS = np.finfo(float).eps


def _wide(rng, m, k, scale=1.0):
    return rng.normal(size=(m, k)) * scale


@pytest.mark.parametrize("shape", [(2, 3, 4), (5, 5, 5), (5, 15, 5), (10, 7, 3)])
def test_mm_is_the_matrix_product_to_rounding(shape, rng):
    """Real and complex (complex times real, complex times complex): each entry within a sum's
    rounding of numpy's product (k products of at most |a||b| each)."""
    m, k, p = shape
    for _ in range(50):
        A, B = rng.normal(size=(m, k)), rng.normal(size=(k, p))
        bound = k * EPS * (np.abs(A) @ np.abs(B))
        assert np.all(np.abs(mm(A, B) - A @ B) <= bound)
        Ac = A + 1j * rng.normal(size=(m, k))
        Bc = B + 1j * rng.normal(size=(k, p))
        for X, Y in ((Ac, B), (Ac, Bc)):
            got = mm(X, Y)
            assert got.dtype == np.complex128
            assert np.all(np.abs(got - X @ Y) <= 4 * k * EPS * (np.abs(X) @ np.abs(Y)))
    view = mm(A.T.T, np.asfortranarray(B))  # any layout
    assert np.all(np.abs(view - A @ B) <= bound)


def test_mv_and_gram_are_numpys_to_rounding(rng):
    """``gram(A)`` is A A^T (plain transpose) and symmetric bit for bit; ``mv`` is A x."""
    for m, k in ((2, 4), (3, 4), (5, 15), (6, 7)):
        A = rng.normal(size=(m, k))
        G = gram(A)
        assert np.array_equal(G, G.T)
        assert np.all(np.abs(G - A @ A.T) <= k * EPS * (np.abs(A) @ np.abs(A).T))
        x = rng.normal(size=k)
        assert np.all(np.abs(mv(A, x) - A @ x) <= k * EPS * (np.abs(A) @ np.abs(x)))
        Ac = A + 1e-20j * rng.normal(size=(m, k))
        Gc = gram(Ac)
        assert np.array_equal(Gc, Gc.T) and np.allclose(Gc, Ac @ Ac.T, rtol=1e-14, atol=0)
    assert np.array_equal(gram(np.empty((3, 0))), np.zeros((3, 3)))  # no columns: A A^T = 0


def test_the_damped_pseudo_inverse_solve_equals_lapacks_inverse(rng):
    """``symmetric_solve_transposed(G, A)`` is A^T G^-1 for the periods' gram matrices (m = 2, 3,
    6, real and complex-step complex), to rounding times G's condition number."""
    for m in (2, 3, 6):
        for _ in range(200):
            A = rng.normal(size=(m, m + 1 + rng.integers(3)))
            G = A @ A.T + 1e-3 * np.eye(m)
            want = A.T @ np.linalg.inv(G)
            got = symmetric_solve_transposed(G, A)
            cond = np.linalg.cond(G)
            assert got.shape == want.shape
            assert np.abs(got - want).max() <= 50 * cond * EPS * np.abs(want).max()


def test_the_complex_step_through_the_solve_is_the_exact_derivative(rng):
    """The kinematic law differentiates A^T (A A^T + l^2 E)^-1 by a complex step: through the
    LDL^T by loops the imaginary part over h equals the analytic derivative
    dP = dA^T G^-1 - P (dA A^T + A dA^T) G^-1 (G's damping held) to rounding."""
    h = 1e-20
    for m in (2, 3, 6):
        A = rng.normal(size=(m, m + 2))
        dA = rng.normal(size=A.shape)
        Ac = A + 1j * h * dA
        Gc = Ac @ Ac.T + 0.01 * np.eye(m)
        P_c = symmetric_solve_transposed(Gc, Ac)
        G = A @ A.T + 0.01 * np.eye(m)
        Gi = np.linalg.inv(G)
        P = A.T @ Gi
        dP = dA.T @ Gi - P @ (dA @ A.T + A @ dA.T) @ Gi
        np.testing.assert_allclose(P_c.real, P, rtol=1e-11, atol=1e-13)
        np.testing.assert_allclose(P_c.imag / h, dP, rtol=1e-9, atol=1e-11)


def test_a_zero_pivot_is_lapacks_singular_matrix_error():
    G = np.array([[1.0, 1.0], [1.0, 1.0]])
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        symmetric_solve_transposed(G, np.eye(2))


@pytest.mark.parametrize("n", [2, 3, 5, 10])
def test_spd_solve_is_lapacks_solve_to_rounding(n, rng):
    """On positive definite systems (the filters' M-hat + c Y Y^T, the gram of Eq. 42): the
    solution within rounding times the condition number of LAPACK's."""
    for _ in range(200):
        B = rng.normal(size=(n, n + 3))
        A = B @ B.T + 10.0 ** rng.uniform(-6, 0) * np.eye(n)
        b = rng.normal(size=n)
        want = np.linalg.solve(A, b)
        got = spd_solve(A, b)
        assert np.abs(got - want).max() <= 20 * np.linalg.cond(A) * EPS * np.abs(want).max()


def test_spd_solve_hands_what_is_not_positive_definite_to_lapack(rng):
    """An indefinite matrix: LAPACK's solution, bit for bit; a singular one or entries that
    are not finite: LAPACK's errors (as ``_array_kernels.solve``)."""
    A = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.5], [0.0, 0.5, 3.0]])  # eigenvalues -1, ...
    b = rng.normal(size=3)
    assert spd_solve(A, b).tobytes() == np.linalg.solve(A, b).tobytes()
    with pytest.raises(np.linalg.LinAlgError):
        spd_solve(np.zeros((3, 3)), b)
    with pytest.raises(np.linalg.LinAlgError):
        spd_solve(np.eye(3), np.array([1.0, np.nan, 0.0]))
    with pytest.raises(np.linalg.LinAlgError):
        spd_solve(np.diag([1.0, np.inf, 1.0]), b)
