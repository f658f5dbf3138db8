"""The planar model's dynamics in theta_d and theta_b: M(q) (Eq. 9a), its rate, C(q, w) w
(Eq. 8), the reaction torque F_r (Eq. 7), the momentum matrices (Eq. 13) and the regressors
the controller needs (Eqs. 12, 14; docs/model.md sections 2-3).

:class:`PlanarDynamics` is the base of :class:`~ffsm_pin.model.planar.BarycentricModel`, which
sets the attributes it reads and gives the configuration's trigonometry
(:meth:`~ffsm_pin.model.planar.BarycentricModel.body_angles`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from typing_extensions import override

from ._common import BarycentricCommon


class BodyAngles(NamedTuple):
    """Trigonometry of one configuration (see :meth:`BarycentricModel.body_angles`)."""

    phi: np.ndarray  # phi_k [rad]
    pos: np.ndarray  # (2, n_V) R(phi_k) u, columns multiplying the V parameters
    rate: np.ndarray  # (2, n_V) R(phi_k) J u
    c: np.ndarray  # cos(phi_l - phi_k) for the pairs k < l
    s: np.ndarray  # sin(phi_l - phi_k)


class PlanarDynamics(BarycentricCommon):
    """The dynamics methods of :class:`~ffsm_pin.model.planar.BarycentricModel` (module
    docstring), which sets these attributes."""

    n_joints: int  # n
    S: np.ndarray  # (n+1, n+1) dphi = S w
    _ST: np.ndarray  # S^T
    _K: np.ndarray  # the pairs k < l: first body
    _L: np.ndarray  # the pairs k < l: second body
    _ar: np.ndarray  # arange(n + 1)
    _diag_cols: np.ndarray  # theta_d columns of Dc_kk
    _pc_cols: np.ndarray  # theta_d columns of Dc_kl, k < l
    _ps_cols: np.ndarray | None  # theta_d columns of Ds_kl (None: collinear)

    def body_angles(self, q_b, q_m) -> BodyAngles:
        """The configuration's trigonometry (given by the model)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ dynamics
    @override
    def mass_matrix(self, theta_d, q_b: float, q_m) -> np.ndarray:
        # M(q, theta_d) of Eq. (9a), (n+1) x (n+1).
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        return self._ST @ self._mass_phi(theta_d, self.body_angles(q_b, q_m)) @ self.S

    def _mass_phi(self, theta_d, ba: BodyAngles) -> np.ndarray:
        nb = self.n_joints + 1
        off = theta_d[self._pc_cols] * ba.c
        if not self.layout.collinear:
            off = off - theta_d[self._ps_cols] * ba.s
        Mphi = np.zeros((nb, nb), dtype=off.dtype)
        Mphi[self._ar, self._ar] = theta_d[:nb]
        Mphi[self._K, self._L] = off
        Mphi[self._L, self._K] = off
        return Mphi

    def _scatter(self, Yp, b, fc, fs):
        """Columns of the pair parameters: f (b_l e_k + b_k e_l) for Dc (fc) and Ds (fs)."""
        bl, bk = b[..., self._L], b[..., self._K]
        Yp[..., self._K, self._pc_cols] = fc * bl
        Yp[..., self._L, self._pc_cols] = fc * bk
        if not self.layout.collinear:
            Yp[..., self._K, self._ps_cols] = fs * bl
            Yp[..., self._L, self._ps_cols] = fs * bk

    @override
    def Y_M(self, q_b: float, q_m, a) -> np.ndarray:
        # Regressor of M(q) a: ``Y_M(q, a) theta_d = M(q, theta_d) a``. Shape (n+1, n_d).
        ba = self.body_angles(q_b, q_m)
        b = self.S @ np.asarray(a, dtype=float)
        Yp = np.zeros((self.n_joints + 1, self.n_d))
        Yp[self._ar, self._diag_cols] = b
        self._scatter(Yp, b, ba.c, -ba.s)
        return self._ST @ Yp

    @override
    def velocity_regressors(self, q_b: float, q_m, w, s_vec) -> tuple[np.ndarray, np.ndarray]:
        # (Y_Mdot(w, s), Y_h(w)) in one pass; see :meth:`Y_Mdot` and :meth:`Y_h`.
        ba = self.body_angles(q_b, q_m)
        nb = self.n_joints + 1
        dphi = self.S @ np.asarray(w, dtype=float)
        b = self.S @ np.asarray(s_vec, dtype=float)
        dd = dphi[self._L] - dphi[self._K]
        Yp = np.zeros((2, nb, self.n_d))
        # dM/dt s: d/dt cos(d) = -sin(d) dd, d/dt(-sin(d)) = -cos(d) dd
        self._scatter(Yp[0], b, -ba.s * dd, -ba.c * dd)
        # C(q, w) w (Lagrange): Dc_kl -> e_k: -sin d dphi_l^2, e_l: +sin d dphi_k^2;
        #                       Ds_kl -> e_k: -cos d dphi_l^2, e_l: +cos d dphi_k^2
        dk2, dl2 = dphi[self._K] ** 2, dphi[self._L] ** 2
        Yp[1, self._K, self._pc_cols] = -ba.s * dl2
        Yp[1, self._L, self._pc_cols] = ba.s * dk2
        if not self.layout.collinear:
            Yp[1, self._K, self._ps_cols] = -ba.c * dl2
            Yp[1, self._L, self._ps_cols] = ba.c * dk2
        Y = self._ST @ Yp
        return Y[0], Y[1]

    @override
    def Y_Mdot(self, q_b: float, q_m, w, s_vec) -> np.ndarray:
        # Regressor of dM/dt s along w: ``Y theta_d = (d/dt M(q(t), theta_d)) s``.
        return self.velocity_regressors(q_b, q_m, w, s_vec)[0]

    @override
    def Y_h(self, q_b: float, q_m, w) -> np.ndarray:
        # Regressor of the velocity product: ``Y theta_d = C(q, w) w`` (Eq. 8).
        return self.velocity_regressors(q_b, q_m, w, np.zeros(self.n_joints + 1))[1]

    @override
    def Y_d(self, q_b: float, q_m, w, s1, s2) -> np.ndarray:
        # Eq. (12) with s3 = w: ``Y_d theta_d = M s1 - dM/dt s2 + C(q, w) w``.
        Y_Mdot, Y_h = self.velocity_regressors(q_b, q_m, w, s2)
        return self.Y_M(q_b, q_m, s1) - Y_Mdot + Y_h

    @override
    def velocity_product(self, theta_d, q_b: float, q_m, w) -> np.ndarray:
        # C(q, w, theta_d) w.
        return self.Y_h(q_b, q_m, w) @ self._check(theta_d, self.n_d, "theta_d")

    @override
    def mass_matrix_rate(self, theta_d, q_b: float, q_m, w) -> np.ndarray:
        # dM/dt (q, w, theta_d), (n+1) x (n+1), column j = Y_Mdot(e_j) theta_d.
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        nb = self.n_joints + 1
        return np.column_stack([self.Y_Mdot(q_b, q_m, w, e) @ theta_d for e in np.eye(nb)])

    @override
    def reaction_torque(self, theta_d, q_b: float, q_m, w, w_dot) -> float:
        # Reaction torque of the manipulator on the base, Eqs. (6)-(7) [N m].
        # ``F_r = M_bb dw_b/dt + C_bb w_b = -(M_bm dw_m/dt + C_bm w_m)`` with the Christoffel C,
        # for which ``C_bb w_b = 1/2 dM_bb/dt w_b`` (M does not depend on q_b). ``w_dot`` =
        # (dw_b/dt, dw_m/dt) [rad/s^2].
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        e0 = np.zeros(self.n_joints + 1)
        e0[0] = 1.0
        M_bb = self.mass_matrix(theta_d, q_b, q_m)[0, 0]
        M_bb_dot = (self.Y_Mdot(q_b, q_m, w, e0) @ theta_d)[0]
        return float(M_bb * w_dot[0] + 0.5 * M_bb_dot * w[0])

    # ------------------------------------------------------------------ momentum
    @override
    def Y_b(self, q_b: float, q_m, w) -> np.ndarray:
        # Regressor of Eq. (14): ``Y_b theta_b = H_bb w_b + H_bm w_m - A_0``. Shape (1, n_b).
        Y = np.empty((1, self.n_b))
        Y[0, 0] = -1.0
        Y[0, 1:] = self.Y_M(q_b, q_m, w)[0]
        return Y

    @override
    def momentum_matrices(self, theta_b, q_b: float, q_m) -> tuple[np.ndarray, np.ndarray, float]:
        # (H_bb (1x1), H_bm (1 x n), A_0) of Eq. (13) from a parameter vector theta_b.
        # H is the first row of M = S^T M_phi S, i.e. ``1^T M_phi S``. Like :meth:`angles`,
        # :meth:`jacobians`, :meth:`ee_offset` and :meth:`mass_matrix`, this accepts complex
        # arguments (used for complex-step derivatives).
        theta_b = self._check(theta_b, self.n_b, "theta_b")
        row = self._mass_phi(theta_b[1:], self.body_angles(q_b, q_m)).sum(axis=0) @ self.S
        return row[None, :1], row[None, 1:], theta_b[0]
