"""Quantities evaluated with the *true* model, for recording and analysis (never for control).

:func:`true_model_terms` gives, at a state, the paper's Eq. (54) residual
``e = M w~ + Y_df (theta_d - theta_d-hat)`` and the base block of the inertia with its time
derivative, from which the run loop forms the reaction torque of Eq. (7). The compiled version
(:mod:`.fast`, :mod:`.fast_spatial`) and the numpy reference are tested against each other.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..model.interface import ReducedModel

TrueModelTerms = Callable[..., tuple]


def numba_available() -> bool:
    """True when the compiled kernels can be imported (numba installed)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def true_model_terms(model: ReducedModel, theta_d: np.ndarray, compiled: bool) -> TrueModelTerms:
    """f(q_b, q_m, w, w~, Y_df, theta_d-hat) -> (e of Eq. 54, M_bb, dM_bb/dt), true model.

    The reaction torque (Eq. 7) follows once the plant's acceleration is known:
    ``F_r = M_bb dw_b/dt + 1/2 dM_bb/dt w_b`` (planar), plus the gyroscopic
    ``1/2 w_b x (M_bb w_b)`` for spatial robots, as the models' ``reaction_torque`` (tested
    against Pinocchio).
    """
    if compiled and model.m3 == 3:
        from . import fast_spatial

        geo = model.kernel_constants()[:2]  # joint rotations, axes

        def compiled_spatial(q_b, q_m, w, w_tilde, Y_df, theta_d_hat):
            return fast_spatial.diagnostics(*geo, q_b, q_m, w, w_tilde, Y_df, theta_d_hat, theta_d)

        return compiled_spatial
    if compiled:
        from . import fast

        k = model.kernel_constants()
        args = (k.S, k.phi_offset, k.K, k.L, k.collinear)

        def compiled_diag(q_b, q_m, w, w_tilde, Y_df, theta_d_hat):
            return fast.diagnostics(*args, q_b, q_m, w, w_tilde, Y_df, theta_d_hat, theta_d)

        return compiled_diag
    m3 = model.m3
    if m3 > 1:
        basis = np.eye(model.n_joints + m3)[:m3]

        def spatial_diag(q_b, q_m, w, w_tilde, Y_df, theta_d_hat):
            M = model.mass_matrix(theta_d, q_b, q_m)
            # columns of the symmetric dM/dt: compiled regressors, as Eq. (7) needs
            Mbb_dot = np.column_stack([model.Y_Mdot(q_b, q_m, w, e)[:m3] @ theta_d for e in basis])
            return M @ w_tilde + Y_df @ (theta_d - theta_d_hat), M[:m3, :m3], Mbb_dot

        return spatial_diag
    e0 = np.zeros(model.n_joints + 1)
    e0[0] = 1.0

    def numpy_diag(q_b, q_m, w, w_tilde, Y_df, theta_d_hat):
        M = model.mass_matrix(theta_d, q_b, q_m)
        Mbb_dot = (model.Y_Mdot(q_b, q_m, w, e0) @ theta_d)[0]
        return M @ w_tilde + Y_df @ (theta_d - theta_d_hat), M[0, 0], Mbb_dot

    return numpy_diag


def base_inertia_terms(model: ReducedModel, theta_d: np.ndarray, compiled: bool):
    """f(q_b, q_m, w) -> (M_bb, dM_bb/dt) of the true model (see :func:`true_model_terms`)."""
    terms = true_model_terms(model, theta_d, compiled)
    nb = model.n_joints + model.m3
    zero, no_Y = np.zeros(nb), np.zeros((nb, model.n_d))

    def base_terms(q_b, q_m, w):
        _, Mbb, Mbb_dot = terms(q_b, q_m, w, zero, no_Y, theta_d)
        return Mbb, Mbb_dot

    return base_terms
