"""The spatial model's dynamics in theta_d and theta_b: M(q) (Eq. 9a), its rate, C(q, w) w
(Eq. 8), the reaction torque F_r (Eqs. 6-7), the momentum matrices (Eq. 13) and the
regressors the controller needs (Eqs. 12, 14; docs/spatial.md sections 3-4).

Real arguments on the numba backend go to the compiled kernels
(:mod:`ffsm_pin.model._spatial_mass_kernels`, :mod:`ffsm_pin.model._spatial_velocity_kernels`);
otherwise the numpy reference's bilinear cores (:class:`SpatialReference`) are evaluated, the
derivatives along the motion and along the joints by a complex step of size ``_H`` (exact for
these bilinear expressions; :mod:`ffsm_pin.model.spatial`).

:class:`SpatialDynamics` is the base of
:class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`, which sets the attributes it reads and
gives the configuration's rotations
(:meth:`~ffsm_pin.model.spatial.SpatialBarycentricModel.kinematics`).
"""

from __future__ import annotations

import numpy as np
from typing_extensions import override

from . import _spatial_mass_kernels as kmass
from . import _spatial_velocity_kernels as kvel
from ._spatial_reference import Kinematics, SpatialReference
from ._state_spatial import reaction_torque as _reaction_torque

_H = 1e-20  # complex step (exact for the bilinear expressions here)


class SpatialDynamics(SpatialReference):
    """The dynamics methods of :class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`
    (module docstring), which sets the attributes of :class:`SpatialReference` and gives
    these three methods."""

    def kinematics(self, q_b, q_m) -> Kinematics:
        """R_k, z_j and S_k of one configuration, real or complex (given by the model)."""
        raise NotImplementedError

    def _use_fast(self, *args) -> bool:
        """Whether the compiled kernels take these arguments (given by the model)."""
        raise NotImplementedError

    def _rz(self, q_b, q_m):
        """(R, z) from the compiled kinematics, real arguments (given by the model)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ dynamics
    @override
    def mass_matrix(self, theta_d, q_b, q_m) -> np.ndarray:
        # M(q, theta_d) of Eq. (9a), (n+3) x (n+3).
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        if self._use_fast(theta_d, q_b, q_m):
            R, z = self._rz(q_b, q_m)
            M = np.empty((self._N, self._N))
            kmass.mass_matrix_by_sums(R, z, np.ascontiguousarray(theta_d), M)
            return M
        kin = self.kinematics(q_b, q_m)
        return self._mass_core(kin.R, kin.S, theta_d)

    @override
    def mass_matrix_rate(self, theta_d, q_b, q_m, w) -> np.ndarray:
        # dM/dt (q, w, theta_d), (n+3) x (n+3), exact (complex step of the numpy reference).
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        kin = self.kinematics(q_b, q_m)
        dR, dS = self._motion_tangent(kin, np.asarray(w, dtype=float))
        return self._mass_core(kin.R + 1j * _H * dR, kin.S + 1j * _H * dS, theta_d).imag / _H

    @override
    def Y_M(self, q_b, q_m, a) -> np.ndarray:
        # Regressor of M(q) a: ``Y_M(q, a) theta_d = M(q, theta_d) a``. Shape (n+3, n_d).
        if self._use_fast(q_b, q_m, a):
            R, z = self._rz(q_b, q_m)
            Y = np.empty((self._N, self.n_d))
            kmass.ym(R, z, np.ascontiguousarray(a, dtype=float), Y, False)
            return Y
        kin = self.kinematics(q_b, q_m)
        return self._ym_core(kin.R, kin.S, np.asarray(a))

    @override
    def velocity_regressors(self, q_b, q_m, w, s_vec) -> tuple[np.ndarray, np.ndarray]:
        # (Y_Mdot(w, s), Y_h(w)) in one pass; see :meth:`Y_Mdot` and :meth:`Y_h`.
        w = np.ascontiguousarray(w, dtype=float)
        s_vec = np.ascontiguousarray(s_vec, dtype=float)
        if self._use_fast(q_b, q_m):
            return self._fast_velocity(q_b, q_m, w, s_vec)
        kin = self.kinematics(q_b, q_m)
        dR, dS = self._motion_tangent(kin, w)
        Rc, Sc = kin.R + 1j * _H * dR, kin.S + 1j * _H * dS
        Y_Mdot = self._ym_core(Rc, Sc, s_vec).imag / _H
        # h = dM/dt w - (0_3, dT/dq_m) (docs/spatial.md section 4)
        Y_h = self._ym_core(Rc, Sc, w).imag / _H
        jR, jS = self._joint_tangents(kin)
        dT = self._energy_core(kin.R + 1j * _H * jR, kin.S + 1j * _H * jS, w).imag / _H
        Y_h[3:] -= dT
        return Y_Mdot, Y_h

    def _fast_velocity(self, q_b, q_m, w, s_vec):
        """(Y_Mdot(w, s), Y_h(w)) from the compiled kernels (real, contiguous w and s)."""
        R, z = self._rz(q_b, q_m)
        N, nd = self._N, self.n_d
        Y_Mdot, Y_h = np.empty((N, nd)), np.empty((N, nd))
        rows = np.empty((3, nd))  # Y_b rows: not used (and Y_M not computed)
        kvel.velocity_terms(R, z, w, w, s_vec, None, Y_Mdot, Y_h, rows)
        kvel.subtract_dT(R, z, w, Y_h)
        return Y_Mdot, Y_h

    @override
    def Y_Mdot(self, q_b, q_m, w, s_vec) -> np.ndarray:
        # Regressor of dM/dt s along w: ``Y theta_d = (d/dt M(q(t), theta_d)) s``.
        w = np.ascontiguousarray(w, dtype=float)
        if self._use_fast(q_b, q_m):
            return self._fast_velocity(q_b, q_m, w, np.ascontiguousarray(s_vec, dtype=float))[0]
        kin = self.kinematics(q_b, q_m)
        dR, dS = self._motion_tangent(kin, w)
        Rc, Sc = kin.R + 1j * _H * dR, kin.S + 1j * _H * dS
        return self._ym_core(Rc, Sc, np.asarray(s_vec, dtype=float)).imag / _H

    @override
    def Y_h(self, q_b, q_m, w) -> np.ndarray:
        # Regressor of the velocity product: ``Y theta_d = C(q, w) w`` (Eq. 8), i.e. of ``h =
        # dM/dt w - (0_3, dT/dq_m)`` (docs/spatial.md section 4).
        w = np.ascontiguousarray(w, dtype=float)
        if self._use_fast(q_b, q_m):
            return self._fast_velocity(q_b, q_m, w, w)[1]
        return self.velocity_regressors(q_b, q_m, w, np.zeros(self._N))[1]

    def Y_T(self, q_b, q_m, w) -> np.ndarray:
        """Regressor of the kinetic energy about the CoM: ``Y_T theta_d = 1/2 w^T M w``.

        Parameters
        ----------
        q_b : ndarray, shape (3,)
            Base attitude, MRP.
        q_m : ndarray, shape (n,)
            Joint angles [rad].
        w : ndarray, shape (n + 3,)
            (w_b, w_m) [rad/s], w_b in the inertial frame.

        Returns
        -------
        ndarray, shape (n_d,)
            The row y with y theta_d = T [J].
        """
        kin = self.kinematics(q_b, q_m)
        return self._energy_core(kin.R, kin.S, np.asarray(w, dtype=float))

    @override
    def Y_d(self, q_b, q_m, w, s1, s2) -> np.ndarray:
        # Eq. (12) with s3 = w: ``Y_d theta_d = M s1 - dM/dt s2 + C(q, w) w``.
        Y_Mdot, Y_h = self.velocity_regressors(q_b, q_m, w, s2)
        return self.Y_M(q_b, q_m, s1) - Y_Mdot + Y_h

    @override
    def velocity_product(self, theta_d, q_b, q_m, w) -> np.ndarray:
        # C(q, w, theta_d) w, (n+3), Eq. (8).
        return self.Y_h(q_b, q_m, w) @ self._check(theta_d, self.n_d, "theta_d")

    @override
    def reaction_torque(self, theta_d, q_b, q_m, w, w_dot) -> np.ndarray:
        # Reaction torque of the manipulator on the base, Eqs. (6)-(7) [N m], 3-vector.
        # ``F_r = M_bb dw_b/dt + 1/2 dM_bb/dt w_b + 1/2 w_b x (M_bb w_b)`` (see
        # :func:`ffsm_pin.model._state_spatial.reaction_torque`).
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        w = np.asarray(w, dtype=float)
        M_bb = self.mass_matrix(theta_d, q_b, q_m)[:3, :3]
        M_bb_dot = self.mass_matrix_rate(theta_d, q_b, q_m, w)[:3, :3]
        return _reaction_torque(M_bb, M_bb_dot, w[:3], np.asarray(w_dot, dtype=float)[:3])

    # ------------------------------------------------------------------ momentum
    @override
    def Y_b(self, q_b, q_m, w) -> np.ndarray:
        # Regressor of Eq. (14): ``Y_b theta_b = H_bb w_b + H_bm w_m - A_0``. Shape (3, n_b).
        Y = np.empty((3, self.n_b))
        Y[:, :3] = -np.eye(3)
        if self._use_fast(q_b, q_m, w):
            R, z = self._rz(q_b, q_m)
            rows = np.empty((3, self.n_d))
            kmass.ym(R, z, np.ascontiguousarray(w, dtype=float), rows, True)
            Y[:, 3:] = rows
        else:
            Y[:, 3:] = self.Y_M(q_b, q_m, w)[:3]
        return Y

    @override
    def momentum_matrices(self, theta_b, q_b, q_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # (H_bb (3x3), H_bm (3 x n), A_0 (3)) of Eq. (13) from a parameter vector theta_b.
        theta_b = self._check(theta_b, self.n_b, "theta_b")
        rows = self.mass_matrix(theta_b[3:], q_b, q_m)[:3]
        return rows[:, :3], rows[:, 3:], theta_b[:3]
