"""Closed-form (semi-implicit) updates of the adaptation laws and the regressor filter.

Each law is linear in its own state for a regressor held over the step, so it is updated
exactly (zero-order hold) or by backward Euler: no step-size limit from the adaptation gains
(docs/model.md section 7: explicit Euler of Eq. (28) is unstable at dt = 1e-3 on the paper robot).
"""

from __future__ import annotations

import numpy as np


def theta_b_step(theta_b: np.ndarray, Y_b: np.ndarray, gamma_1: float, dt: float) -> np.ndarray:
    """Eq. (28) ``dtheta_b/dt = -Gamma_1 Y_b^T Y_b theta_b``, exact for Y_b constant over dt.

    With ``G = Y_b Y_b^T`` (m3 x m3): ``exp(-g dt Y^T Y) = I - Y^T G^-1 (I - exp(-g dt G)) Y``.
    The update is a contraction: ``|theta_b|`` never increases.

    Parameters
    ----------
    theta_b : ndarray
        The estimate at t.
    Y_b : ndarray, shape (m3, n_b)
        The regressor of Eq. (28), constant over the step.
    gamma_1 : float
        Adaptation gain.
    dt : float
        Step [s]; exact at any step for Y_b constant over it.

    Returns
    -------
    ndarray
        theta_b-hat at t + dt.
    """
    G = Y_b @ Y_b.T
    if not np.any(G):
        return theta_b.copy()
    lam, V = np.linalg.eigh(G)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(lam > 0, -np.expm1(-gamma_1 * dt * lam) / lam, gamma_1 * dt)
    return theta_b - Y_b.T @ (V @ (f * (V.T @ (Y_b @ theta_b))))


def theta_z_step(
    theta_z: np.ndarray, Y_z: np.ndarray, measured: np.ndarray, gamma_2: float, dt: float
) -> np.ndarray:
    """Eq. (42) ``dtheta_z/dt = Gamma_2 Y_z^T (measured - Y_z theta_z)`` by backward Euler.

    ``measured`` is the part of the measured end-effector velocity that Y_z theta_z predicts
    (the parameter-free rows removed). The estimation error contracts: with
    ``measured = Y_z theta_z``, ``|theta_z - theta_z-hat|`` never increases (Eq. 43).

    Parameters
    ----------
    theta_z : ndarray
        The estimate at t.
    Y_z : ndarray
        The kinematic regressor of Eq. (42).
    measured : ndarray
        The measured end-effector velocity's part that Y_z theta_z predicts.
    gamma_2 : float
        Adaptation gain.
    dt : float
        Step [s] (backward Euler: stable at any step).

    Returns
    -------
    ndarray
        theta_z-hat at t + dt.
    """
    r = measured - Y_z @ theta_z
    gram = Y_z @ Y_z.T + np.eye(len(r)) / (gamma_2 * dt)
    return theta_z + Y_z.T @ np.linalg.solve(gram, r)


def regressor_filter_step(Y_df: np.ndarray, Y_dc: np.ndarray, k_de: float, dt: float):
    """Eq. (50) ``dY_df/dt + k_de Y_df = Y_dc``, exact for Y_dc constant over dt.

    Parameters
    ----------
    Y_df : ndarray
        The filtered regressor at t.
    Y_dc : ndarray
        The regressor fed to the filter, constant over the step.
    k_de : float
        Filter rate [1/s].
    dt : float
        Step [s]; exact for Y_dc constant over it.
    """
    decay = np.exp(-k_de * dt)
    return decay * Y_df + (-np.expm1(-k_de * dt) / k_de) * Y_dc


def theta_d_increment(
    Y_df: np.ndarray, w_tilde: np.ndarray, M_hat: np.ndarray, gamma_3: float, dt: float
) -> np.ndarray:
    """Eq. (51) ``dtheta_d/dt = -Gamma_3 Y_df^T w~``, linearly implicit in the stiff mode.

    Along the closed loop ``w~ = M^-1 (e - Y_df theta~_d)`` (Eq. 54), so the law is stiff with
    rate ``Gamma_3 Y_df^T M^-1 Y_df``. Taking ``w~`` at the end of the step,
    ``w~ + M-hat^-1 Y_df dtheta``, gives
    ``dtheta = -c Y_df^T (M-hat + c Y_df Y_df^T)^-1 M-hat w~`` with ``c = Gamma_3 dt``
    ((n+1) x (n+1) solve), which tends to the explicit step as ``c -> 0``. The filter of
    Eq. (46) receives ``eta_x = -Y_df dtheta / dt`` (Eq. 52), so ``w-hat`` moves consistently.

    Parameters
    ----------
    Y_df : ndarray
        The filtered regressor (Eq. 50).
    w_tilde : ndarray, shape (m3 + n,)
        The filter's velocity error w~.
    M_hat : ndarray
        The estimated inertia M-hat.
    gamma_3 : float
        Adaptation gain.
    dt : float
        Step [s]; c = Gamma_3 dt sets how implicit the step is.

    Returns
    -------
    ndarray
        The increment dtheta of theta_d-hat over the step.
    """
    c = gamma_3 * dt
    return -c * (Y_df.T @ np.linalg.solve(M_hat + c * (Y_df @ Y_df.T), M_hat @ w_tilde))
