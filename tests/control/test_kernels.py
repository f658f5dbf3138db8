"""The compiled kernels shared by the planar and spatial periods equal their numpy references:
the funnel transformation (control/funnel.py: psi, Phi inside, and the same exit index
outside) and the damped right pseudo-inverse (control/linalg.py: damped_row_pinv); the two
decisions the periods make by cheaper means than LAPACK (M-hat positive definite, the base rows'
3x3 matrix regular) are LAPACK's decisions."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin._array_kernels import (
    add_scaled,
    difference,
    positive_definite,
    smallest_singular_value_above,
)
from ffsm_pin.control.funnel import Funnel, FunnelExit, FunnelParams
from ffsm_pin.control.kernels import (
    damped_pinv,
    filter_input_update,
    filter_regressor_update,
    funnel_constants,
    funnel_terms,
)
from ffsm_pin.control.linalg import damped_row_pinv

PARAMS = FunnelParams((2.0, 0.5, 0.3), (0.1, 0.2, 0.01), (1.5, 0.05, 0.7), (1.0, 0.3, 0.55))


@pytest.mark.parametrize("dtype", [float, complex])
def test_inside_equals_the_numpy_funnel(dtype, rng):
    funnel = Funnel(PARAMS, np.array([0.1, -0.05, 0.02]))
    constants = funnel_constants(funnel)
    for t in (0.0, 0.7, 3.0):
        lo, hi = funnel.bounds(t)
        e = (lo + (hi - lo) * rng.uniform(0.05, 0.95, 3)).astype(dtype)
        if dtype is complex:
            e = e + 1e-20j * rng.normal(size=3)  # a complex step
        ref = funnel.evaluate(t, e)
        psi, Phi, idx = funnel_terms(constants, t, e, False)
        assert idx == -1
        np.testing.assert_allclose(psi, ref.psi, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(Phi, ref.Phi, rtol=1e-14, atol=1e-15)
        if dtype is complex:  # the imaginary parts carry the derivative: they must agree too
            np.testing.assert_allclose(psi.imag, ref.psi.imag, rtol=1e-12, atol=1e-40)


def test_exit_index_is_the_reference_one():
    """Two components beyond their bounds: the one farther beyond is reported (before this
    kernel was shared, the planar period reported the first of the two)."""
    funnel = Funnel(PARAMS, np.array([0.1, 0.1, 0.1]))
    lo, hi = funnel.bounds(0.0)
    e = np.array([1.01 * hi[0], 0.0, 3.0 * hi[2]])  # component 2 is farther out
    with pytest.raises(FunnelExit) as exc:
        funnel.evaluate(0.0, e)
    _, _, idx = funnel_terms(funnel_constants(funnel), 0.0, e, False)
    assert idx == exc.value.index == 2


def test_identity_passes_the_error_through():
    funnel = Funnel(PARAMS, np.ones(3))
    e = np.array([5.0, -7.0, 0.3])  # far outside: no refusal without prescribed performance
    psi, Phi, idx = funnel_terms(funnel_constants(funnel), 1.0, e, True)
    assert idx == -1
    np.testing.assert_array_equal(psi, e)
    np.testing.assert_array_equal(Phi, np.ones(3))


# ------------------------------------------------------------------ damped pseudo-inverse
def _with_singular_values(rng, singular_values, n_cols):
    m = len(singular_values)
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n_cols, n_cols)))
    return U @ np.diag(singular_values) @ V[:m]


@pytest.mark.parametrize(("rows", "cols"), [(3, 3), (3, 4), (6, 7), (6, 9)])  # planar, spatial
@pytest.mark.parametrize("smallest", [0.4, 0.01], ids=["undamped", "damped"])
def test_damped_pinv_equals_the_numpy_reference(rng, rows, cols, smallest):
    """One compiled kernel for both geometries and the baselines: value, sigma_min and
    damping of control/linalg.damped_row_pinv, and at a complex step the same derivative (the
    kinematic law differentiates through it)."""
    thr = 0.05
    for _ in range(5):
        a = _with_singular_values(rng, np.linspace(1.5, smallest, rows), cols)
        da = rng.normal(size=a.shape)
        ref = damped_row_pinv(a, thr)
        pinv, sigma, damping = damped_pinv(a.astype(complex), thr)
        assert (damping > 0) == (smallest < thr) == (ref.damping > 0)
        np.testing.assert_allclose(sigma, ref.sigma_min, rtol=1e-10)
        np.testing.assert_allclose(damping, ref.damping, rtol=1e-10, atol=1e-18)
        np.testing.assert_allclose(pinv.real, ref.pinv, rtol=1e-10, atol=1e-12)
        h = 1e-30  # the complex step (damping held at its real value, as the reference)
        step = damped_pinv(a + 1j * h * da, thr)[0].imag / h
        np.testing.assert_allclose(step, damped_row_pinv(a + 1j * h * da, thr).pinv.imag / h,
                                   rtol=1e-9, atol=1e-10)  # fmt: skip


# ------------------------------------------------------------------ null-space objective
def test_null_space_objective_kernels_equal_the_numpy_reference(rng):
    """The objective's compiled pieces (joint centering; mu and its central difference over
    the rows of perturbed_joints) against control/null_space.py on a smooth made-up
    A(q_m) = J_m U of the right shape, at complex arguments as in the kinematic law."""
    from ffsm_pin.control import null_space as ref
    from ffsm_pin.control.kernels import (
        joint_centering_gradient,
        manipulability_gradient,
        null_space_term,
        perturbed_joints,
    )

    n, rows = 7, 6
    B, C = rng.normal(size=(rows, n)), rng.normal(size=(rows, n))

    def reduced_jacobian(q):  # analytic in q, so complex steps pass through
        return B * np.cos(q)[None, :] + C * np.sin(2 * q)[None, :]

    q_m = rng.normal(size=n) + 1e-20j * rng.normal(size=n)
    center = rng.normal(size=n)
    for objective in ("manipulability", "joint-centering"):
        spec = ref.NullSpace(objective=objective, gain=0.5)
        ns = null_space_term(spec, center, n)
        expected = ref.null_space_gradient(spec, center, q_m, reduced_jacobian)
        if objective == "joint-centering":
            got = joint_centering_gradient(ns, q_m)
        else:
            Q = perturbed_joints(q_m, ns.step)
            got = manipulability_gradient(np.array([reduced_jacobian(q) for q in Q]), ns.step)
        # the central difference divides mu's rounding (~1e-16 mu, the products' order
        # differs) by the step (null_space.GRADIENT_STEP): ~1e-10 relative; 1e-8 allowed
        np.testing.assert_allclose(got.real, expected.real, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(got.imag, expected.imag, rtol=1e-8, atol=1e-40)


def _with_eigenvalues(rng, lam):
    """A random symmetric matrix with eigenvalues ``lam``."""
    Q, _ = np.linalg.qr(rng.normal(size=(len(lam), len(lam))))
    A = Q @ np.diag(lam) @ Q.T
    return 0.5 * (A + A.T)


@pytest.mark.parametrize("n", [4, 5, 10])
def test_positive_definite_is_the_eigenvalue_decision(rng, n):
    """Cholesky's decision is LAPACK's smallest-eigenvalue decision for well-separated cases
    (mass-matrix-like scales, condition up to 1e8) and for indefinite or singular ones."""
    for smallest in (1e-8, 1e-3, 1.0, -1e-6, -1.0):
        for _ in range(20):
            lam = np.sort(rng.uniform(0.1, 50.0, n))
            lam[0] = smallest * lam[-1]
            A = _with_eigenvalues(rng, lam)
            assert positive_definite(A) == (np.linalg.eigvalsh(A)[0] > 0), (n, smallest)


def test_positive_definite_falls_back_to_lapack_when_a_pivot_fails():
    """A pivot that is not positive hands the decision to eigvalsh: a matrix with a zero first
    diagonal entry is never PD, and the answer is False as LAPACK's."""
    A = np.array([[0.0, 1.0], [1.0, 2.0]])
    assert not positive_definite(A)
    assert not positive_definite(-np.eye(3))
    assert positive_definite(np.diag([1e-300, 1.0, 1e300]))


@pytest.mark.parametrize("sigma3", [1e-14, 1e-12, 9e-13, 1.1e-12, 1e-9, 1e-3, 1.0])
def test_base_rows_regularity_is_the_svd_decision(rng, sigma3):
    """The determinant bound never contradicts the SVD: over random 3x3 matrices with a
    chosen smallest singular value around the period's tolerance (1e-12 |M_bb|), the decision
    is ``svd(A)[1][2] > tol``, and the value is the SVD's whenever the SVD decided."""
    for _ in range(50):
        U, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        V, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        s = np.array([rng.uniform(0.5, 20.0), rng.uniform(0.1, 5.0), sigma3])
        A = U @ np.diag(s) @ V.T
        tol = 1e-12 * rng.uniform(0.5, 2.0)
        exact = np.linalg.svd(A)[1][2]
        regular, value = smallest_singular_value_above(A, tol)
        if abs(exact - tol) > 1e-6 * tol:  # (a tie at rounding level is either answer)
            assert regular == (exact > tol), (sigma3, exact, tol)
        if not np.isnan(value):
            assert value == pytest.approx(exact, rel=1e-9, abs=1e-15)
    assert smallest_singular_value_above(np.zeros((3, 3)), 1e-12) == (False, 0.0)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e6])
def test_the_determinant_bound_decides_clear_cases_and_is_never_wrong(rng, scale):
    """Clearly regular matrices are decided by the bound (no SVD: the value is NaN); at
    sigma_3 just above the tolerance, with sigma_1 = sigma_2 (where the bound is tightest) and
    at large and small scales, a True from the bound is always the SVD's True."""
    bound_decided = 0
    for _ in range(200):
        U, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        V, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        tol = 1e-12 * scale
        s1 = scale * rng.uniform(0.5, 2.0)
        s3 = tol * (1.0 + rng.choice([1e-14, 1e-10, 1e-6, 1e-2, 1.0, 1e6]))
        A = U @ np.diag([s1, s1, s3]) @ V.T
        regular, value = smallest_singular_value_above(A, tol)
        if np.isnan(value):
            bound_decided += 1
            assert regular and np.linalg.svd(A)[1][2] > tol
    assert bound_decided > 0
    A = U @ np.diag([scale, scale, scale]) @ V.T  # well conditioned: the bound decides
    regular, value = smallest_singular_value_above(A, tol)
    assert regular and np.isnan(value)


def test_loops_give_the_bits_of_the_array_expressions(rng):
    """difference, add_scaled (adaptive-ct's polarization), filter_regressor_update and
    filter_input_update (Eq. 50) equal the numpy expressions they replace byte for byte,
    signed zeros included."""
    shape = (10, 33)
    Y_df, YM, YMdot, Yh = (rng.normal(size=shape) for _ in range(4))
    for arr in (Y_df, YM, YMdot, Yh):  # signed zeros where the sums cancel
        arr[rng.random(shape) < 0.2] = 0.0
        arr[rng.random(shape) < 0.1] = -0.0
    YMdot[:, :3] = YM[:, :3]  # exact cancellations
    assert difference(YMdot, Yh).tobytes() == (YMdot - Yh).tobytes()
    for c in (0.25, -0.25, 0.1):
        got, expected = YM.copy(), YM.copy()
        add_scaled(got, c, Yh)
        expected += c * Yh
        assert got.tobytes() == expected.tobytes(), c
    decay, gain = np.exp(-0.3e-3), -np.expm1(-0.3e-3) / 0.3
    expected = decay * Y_df + gain * (YM - YMdot + Yh)
    Y_dc = YM - YMdot + Yh
    Y_df2 = Y_df.copy()
    filter_regressor_update(Y_df, decay, gain, YM, YMdot, Yh)
    assert Y_df.tobytes() == expected.tobytes()
    filter_input_update(Y_df2, decay, gain, Y_dc)  # the same input formed beforehand
    assert Y_df2.tobytes() == expected.tobytes()
