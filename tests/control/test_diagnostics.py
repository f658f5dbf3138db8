"""The true-model quantities the run records (control/diagnostics.py): the compiled kernels
equal the numpy reference, the reference equals its definition (Eq. 54) and the reaction torque
it yields equals the model's reaction_torque (itself checked against Pinocchio in tests/model)."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control import fast, fast_spatial
from ffsm_pin.control.diagnostics import reaction_torques, residual_54

pytest.importorskip("numba")


def _compiled_base_inertia(model, theta_d):
    """The kernels' f(q_b, q_m, w) -> (M_bb, dM_bb/dt) of the true model."""
    if model.m3 == 3:
        jr, ax = model.kernel_constants()[:2]
        return lambda q_b, q_m, w: fast_spatial.base_inertia(jr, ax, q_b, q_m, w, theta_d)
    k = model.kernel_constants()
    geo = (k.S, k.phi_offset, k.K, k.L, k.collinear)
    return lambda q_b, q_m, w: fast.base_inertia(*geo, q_b, q_m, w, theta_d)


def _reference_base_inertia(model, theta_d, q_b, q_m, w):
    """(M_bb, dM_bb/dt) from the numpy model: M's base block, and the columns of the
    symmetric dM/dt as its regressor times theta_d, one base direction each."""
    m3 = model.m3
    M = model.mass_matrix(theta_d, q_b, q_m)
    basis = np.eye(model.n_joints + m3)[:m3]
    Mbb_dot = np.column_stack([model.Y_Mdot(q_b, q_m, w, e)[:m3] @ theta_d for e in basis])
    if m3 == 1:
        return M[0, 0], Mbb_dot[0, 0]
    return M[:m3, :m3], Mbb_dot


def _recorded_rows(model, rng, rows: int) -> tuple:
    """Random recorded rows as a run stores them: q_b (N, m3), q_m, w, dw/dt (N, n + m3) and
    dw_b, the base's part of dw/dt, (N,) planar or (N, 3) spatial."""
    m3, nb, n = model.m3, model.n_joints + model.m3, model.n_joints
    q_b = rng.uniform(-3, 3, (rows, 1)) if m3 == 1 else rng.uniform(-0.4, 0.4, (rows, 3))
    q_m = rng.uniform(-2, 2, (rows, n))
    w = rng.normal(size=(rows, nb))
    w_dot = rng.normal(size=(rows, nb))
    return q_b, q_m, w, w_dot, (w_dot[:, 0] if m3 == 1 else w_dot[:, :3])


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_compiled_equals_reference_and_definition(geometry, reduced_model_of):
    model = reduced_model_of(geometry)
    m3, nb = model.m3, model.n_joints + model.m3
    theta_d = np.array(model.theta_d)
    rng = np.random.default_rng(4)
    funcs = {c: residual_54(model, theta_d, c) for c in (0, 1)}
    compiled_base_inertia = _compiled_base_inertia(model, theta_d)
    for _ in range(4):
        q_b = rng.uniform(-3, 3) if m3 == 1 else rng.uniform(-0.4, 0.4, 3)
        q_m = rng.uniform(-2, 2, model.n_joints)
        w, w_tilde, w_dot = rng.normal(size=(3, nb))
        Y_df = rng.normal(size=(nb, model.n_d))
        theta_hat = theta_d * (1 + 0.2 * rng.uniform(-1, 1, model.n_d))
        e_ref, e_fast = (funcs[c](q_b, q_m, w_tilde, Y_df, theta_hat) for c in (0, 1))
        M = model.mass_matrix(theta_d, q_b, q_m)
        np.testing.assert_allclose(e_ref, M @ w_tilde + Y_df @ (theta_d - theta_hat), rtol=1e-14)
        np.testing.assert_allclose(e_fast, e_ref, rtol=1e-11, atol=1e-11)
        Mbb, Mbb_dot = _reference_base_inertia(model, theta_d, q_b, q_m, w)
        Mbb_f, Mbb_dot_f = compiled_base_inertia(q_b, q_m, w)
        np.testing.assert_allclose(Mbb_f, Mbb, rtol=1e-12)
        np.testing.assert_allclose(Mbb_dot_f, Mbb_dot, rtol=1e-9, atol=1e-9 * np.max(np.abs(M)))
        np.testing.assert_allclose(np.atleast_2d(Mbb), np.atleast_2d(M[:m3, :m3]), rtol=1e-14)
        # the reaction torque of Eq. (7) from these terms, as the after-run pass forms it
        F_r = model.reaction_torque(theta_d, q_b, q_m, w, w_dot)
        if m3 == 1:
            mine = Mbb_f * w_dot[0] + 0.5 * Mbb_dot_f * w[0]
        else:
            from ffsm_pin.model._state_spatial import reaction_torque

            mine = reaction_torque(Mbb_f, Mbb_dot_f, w[:3], w_dot[:3])
        np.testing.assert_allclose(mine, F_r, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_reaction_torques_after_the_run_equal_the_model_row_by_row(geometry, reduced_model_of):
    """F_r computed after a run on a block of recorded rows (one compiled pass, and the numpy
    reference) equals the model's reaction_torque (Eq. 7) row by row; the planar pass is also
    bitwise the per-row formula the run loop used (the spatial one was checked bitwise on the
    built-in cases with tools/compare_runs.py, its matrix products are BLAS calls)."""
    model = reduced_model_of(geometry)
    m3 = model.m3
    theta_d = np.array(model.theta_d)
    rows = 5
    q_b, q_m, w, w_dot, dw_b = _recorded_rows(model, np.random.default_rng(7), rows)
    fast, ref = (reaction_torques(model, theta_d, c)(q_b, q_m, w, dw_b) for c in (True, False))
    assert fast.shape == ref.shape == ((rows,) if m3 == 1 else (rows, 3))
    per_row = _compiled_base_inertia(model, theta_d)
    for i in range(rows):
        qb = q_b[i, 0] if m3 == 1 else q_b[i]
        F_r = model.reaction_torque(theta_d, qb, q_m[i], w[i], w_dot[i])
        np.testing.assert_allclose(fast[i], F_r, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(ref[i], F_r, rtol=1e-9, atol=1e-9)
        Mbb, Mbb_dot = per_row(qb, q_m[i], w[i])
        if m3 == 1:
            np.testing.assert_array_equal(fast[i], Mbb * dw_b[i] + 0.5 * Mbb_dot * w[i, 0])


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_reaction_torques_in_two_threads_equal_one_pass(geometry, reduced_model_of, monkeypatch):
    """Long recordings are split over two threads (the kernel releases the GIL): the rows are
    independent, so the result is bitwise the single pass's, odd row counts included."""
    from ffsm_pin.control import diagnostics

    model = reduced_model_of(geometry)
    theta_d = np.array(model.theta_d)
    q_b, q_m, w, _, dw_b = _recorded_rows(model, np.random.default_rng(3), 7)
    f = reaction_torques(model, theta_d, True)
    one_pass = f(q_b, q_m, w, dw_b)
    monkeypatch.setattr(diagnostics, "THREAD_ROWS", 2)
    np.testing.assert_array_equal(f(q_b, q_m, w, dw_b), one_pass)
