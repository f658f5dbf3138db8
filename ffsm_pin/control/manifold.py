"""Dynamic level: the attractive-manifold filter w-hat (Eq. 46) and the input u_m (Eqs. 60-64).

The filter (typo-corrected, docs/model.md section 5)::

    M-hat dw-hat/dt - dM-hat/dt w~ + C-hat w = k_de M-hat w~ + eta_x + u,   u = (0, u_m)  # (46)

Write ``r = dM-hat/dt w~ - C-hat w + k_de M-hat w~ + eta_x`` so that ``M-hat dw-hat/dt = r + u``.
The input (64) makes ``d w-hat_{m,r}/dt = -k_d w-hat_{m,r}`` (Eq. 65) with
``w-hat_{m,r} = w-hat_m - w_mc``: the joint rows of the filter are prescribed,
``dw-hat_m/dt = dw_mc/dt - k_d w-hat_{m,r}``, the base row (60a) gives ``dw-hat_b/dt``
and the joint rows (60b) give ``u_m`` (Eqs. 62-64 are this elimination written out).

For Eq. (81) ``dw_mc/dt`` contains ``(d w_mc / d w_b) dw_b/dt``; ``dw_b/dt`` is taken as the
filter's own ``dw-hat_b/dt`` and solved for together with (60a) (docs/model.md section 5).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import SimulationError


class ManifoldInput(NamedTuple):
    """u_m and the filter's rates for one step."""

    u_m: np.ndarray  # joint torques [N m]
    w_hat_dot: np.ndarray  # d w-hat / dt, Eq. (46) [rad/s^2]
    w_mc_dot: np.ndarray  # d w_mc / dt actually used (incl. the w_b term of Eq. 81)


def manifold_input(
    M_hat: np.ndarray,
    r: np.ndarray,
    w_hat: np.ndarray,
    w_mc: np.ndarray,
    w_mc_dot: np.ndarray,
    dwmc_dwb: np.ndarray,
    k_d: float,
    t: float = float("nan"),
) -> ManifoldInput:
    """Solve Eqs. (60a) and (64)-(65) for ``dw-hat/dt`` and ``u_m``.

    The base rows (60a) are ``(M_bb + M_bm dw_mc/dw_b) dw-hat_b/dt = r_b - M_bm target``.

    Parameters
    ----------
    M_hat : ndarray, shape (m3 + n, m3 + n)
        Estimated reduced inertia.
    r : ndarray, shape (m3 + n,)
        Right-hand side of Eq. (46) without u.
    w_hat : ndarray, shape (m3 + n,)
        The filter's state w-hat [rad/s].
    w_mc, w_mc_dot : ndarray, shape (n,)
        Commanded joint rates [rad/s] and their derivative [rad/s^2].
    dwmc_dwb : ndarray, shape (n, m3)
        d w_mc / d w_b (zero except for Eq. 81).
    k_d : float
        Sliding rate of Eq. (64) [1/s].
    t : float
        Time [s], for the error message of a singular base row.

    Returns
    -------
    ManifoldInput
        u_m [N m], dw-hat/dt and the d w_mc / dt used.
    """
    m3 = M_hat.shape[0] - len(w_mc)
    if m3 == 1:  # planar: the scalar base row, as the compiled kernel writes it
        return _planar(M_hat, r, w_hat, w_mc, w_mc_dot, np.ravel(dwmc_dwb), k_d, t)
    Mbb, Mbm = M_hat[:m3, :m3], M_hat[:m3, m3:]
    dwmc_dwb = np.asarray(dwmc_dwb).reshape(len(w_mc), m3)
    target = w_mc_dot - k_d * (w_hat[m3:] - w_mc)  # Eq. (65), without the w_b term
    denom = Mbb + Mbm @ dwmc_dwb
    smallest = np.linalg.svd(denom, compute_uv=False)[-1]
    if not smallest > 1e-12 * np.max(np.abs(Mbb)):
        raise SimulationError(
            f"t = {t:.4f} s: base rows of the filter are singular (sigma_min(M_bb-hat + "
            f"M_bm-hat dw_mc/dw_b) = {smallest:.3g})",
            time=t,
            cause="singular",
        )
    wb_dot = np.linalg.solve(denom, r[:m3] - Mbm @ target)  # Eq. (60a)
    wm_dot = target + dwmc_dwb @ wb_dot
    w_hat_dot = np.concatenate((wb_dot, wm_dot))
    u_m = M_hat[m3:] @ w_hat_dot - r[m3:]  # Eq. (60b) = (64)
    return ManifoldInput(u_m, w_hat_dot, w_mc_dot + dwmc_dwb @ wb_dot)


def _planar(M_hat, r, w_hat, w_mc, w_mc_dot, dwmc_dwb, k_d, t) -> ManifoldInput:
    """Eqs. (60a), (64)-(65) with m3 = 1 (scalar base row)."""
    Mbb, Mbm = M_hat[0, 0], M_hat[0, 1:]
    target = w_mc_dot - k_d * (w_hat[1:] - w_mc)  # Eq. (65), without the w_b term
    denom = Mbb + Mbm @ dwmc_dwb
    if not abs(denom) > 1e-12 * abs(Mbb):
        raise SimulationError(
            f"t = {t:.4f} s: base row of the filter is singular (M_bb-hat + M_bm-hat dw_mc/dw_b "
            f"= {denom:.3g})",
            time=t,
            cause="singular",
        )
    wb_dot = (r[0] - Mbm @ target) / denom  # Eq. (60a)
    wm_dot = target + dwmc_dwb * wb_dot
    w_hat_dot = np.concatenate(([wb_dot], wm_dot))
    u_m = M_hat[1:] @ w_hat_dot - r[1:]  # Eq. (60b) = (64)
    return ManifoldInput(u_m, w_hat_dot, w_mc_dot + dwmc_dwb * wb_dot)
