"""The paper's parametric model: barycentric vectors, theta_z, theta_d, theta_b and regressors.

Bodies k = 0..n (0 = base). The absolute angle of body k is
``phi_k = q_b + sum_{j<=k} s_j q_j + const_k``, i.e. ``dphi = S w`` with the constant
lower-triangular ``S``. Positions about the system CoM are sums of vectors fixed in the
bodies (Vafa & Dubowsky's virtual manipulator, the paper's ref. [12]; docs/model.md section 2):

* ``c_i - p_com = sum_k R(phi_k) W_ik``, ``p_e - p_com = sum_k R(phi_k) V_k``;
* reduced kinetic energy ``T = 1/2 dphi^T M_phi dphi`` with
  ``M_phi[k, l] = Dc_kl cos(phi_l - phi_k) - Ds_kl sin(phi_l - phi_k)``,
  ``Dc_kl = sum_i m_i W_ik . W_il + I_k delta_kl``, ``Ds_kl = sum_i m_i W_ik x W_il``;
* ``M(q) = S^T M_phi S`` is the paper's M (Eq. 9a), the Schur complement of Pinocchio's CRBA.

Parameter vectors (sizes for n links):

* ``theta_z = col(v_0, V_0, ..., V_n)`` (Eq. 4). When the geometry is *collinear* (every
  body's CoM, child joint and end effector on one line through its own joint) each V_k is a
  scalar along that line: 2 + (n+1) entries (7 for the paper's robot). Otherwise each V_k is
  a 2-vector in body k's frame: 2 + 2(n+1) entries.
* ``theta_d = (Dc_00 .. Dc_nn, Dc_kl for k<l row-major, [Ds_kl for k<l])`` (Eq. 12):
  (n+1)(n+2)/2 entries collinear (15), plus n(n+1)/2 otherwise.
* ``theta_b = col(A_0, theta_d)`` (Eq. 14), with ``Y_b = [-1, y(q, w)]``.

The attitude row of ``z_e`` (the end-effector angle) is parameter-free: its rate is
``S[ee] w``, a sum of +-1 joint rates; it is added as a known term and not estimated.

Everything is vectorised over the pairs k < l; the regressors are the three products of
Eq. (12) the controller needs (docs/model.md section 3): ``M(q) a``, ``dM/dt(q, w) s`` and
``C(q, w) w``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .._arrays import read_only
from ..errors import ParameterError
from ..robot import PlanarGeometry
from ._common import BarycentricCommon, barycentric_vectors

_COLLINEAR_TOL = 1e-12


@dataclass(frozen=True)
class ParameterLayout:
    """Sizes and meaning of the parameter vectors.

    Parameters
    ----------
    n_bodies : int
        n + 1.
    collinear : bool
        The paper's collinear layout (no Ds_kl parameters).
    """

    n_bodies: int  # n + 1
    collinear: bool

    @property
    def n_pairs(self) -> int:
        """Number of body pairs k < l (the off-diagonal D_kl)."""
        return self.n_bodies * (self.n_bodies - 1) // 2

    @property
    def n_z(self) -> int:
        """n_1, size of theta_z."""
        return 2 + self.n_bodies * (1 if self.collinear else 2)

    @property
    def n_d(self) -> int:
        """n_2, size of theta_d."""
        return self.n_bodies + self.n_pairs * (1 if self.collinear else 2)

    @property
    def n_b(self) -> int:
        """n_3, size of theta_b."""
        return 1 + self.n_d

    def theta_d_names(self) -> list[str]:
        """Names of the theta_d entries, in the vector's order (Eq. 12)."""
        nb = self.n_bodies
        names = [f"Dc{k}{k}" for k in range(nb)]
        pairs = [(k, l) for k in range(nb) for l in range(k + 1, nb)]
        names += [f"Dc{k}{l}" for k, l in pairs]
        if not self.collinear:
            names += [f"Ds{k}{l}" for k, l in pairs]
        return names

    def theta_z_names(self) -> list[str]:
        """Names of the theta_z entries, in the vector's order (Eq. 4)."""
        names = ["v0x", "v0y"]
        for k in range(self.n_bodies):
            names += [f"V{k}"] if self.collinear else [f"V{k}x", f"V{k}y"]
        return names


class PlanarKernelConstants(NamedTuple):
    """The arrays the compiled planar kernels take for a robot (``control/fast.py``); its type
    selects the planar steps of the one compiled period (``control/period.py``)."""

    S: np.ndarray  # (n+1, n+1) body angle = S @ (q_b, q_m) + phi_offset
    phi_offset: np.ndarray  # (n+1,) [rad]
    K: np.ndarray  # (P,) first body of each pair k < l
    L: np.ndarray  # (P,) second body of each pair
    ee_row: np.ndarray  # (n+1,) end-effector angle row of Eq. (3)
    collinear: bool  # the paper's collinear layout (no Ds_kl parameters)


class BarycentricModel(BarycentricCommon):
    """The reduced, parametric free-floating model of a planar serial chain.

    Configuration arguments ``q_b`` [rad] and ``q_m`` [rad] are the base attitude and the
    joint angles; velocity arguments ``w = (w_b, w_m)`` [rad/s].
    """

    m2, m3 = 2, 1  # end-effector position / attitude components (the paper's planar case)

    def __init__(self, geometry: PlanarGeometry):
        g = geometry
        n = g.n_joints
        nb = n + 1
        self.geometry = g
        self.n_joints = n
        a, W, V = barycentric_vectors(g, 2)  # a_k: child joint of body k, zero for the last
        m = g.ee_body

        # collinear: every body's vectors (c_k, a_k, e) span at most a line u_k
        scale = max(1.0, float(np.abs(np.concatenate([a.ravel(), g.coms.ravel()])).max()))
        alpha = np.zeros(nb)
        collinear = True
        for k in range(nb):
            points = [g.coms[k]]
            if k < n:
                points.append(a[k])
            if k == m:
                points.append(g.ee_position)
            vecs = np.array(points)
            sv = np.linalg.svd(vecs, compute_uv=False)
            if len(sv) > 1 and sv[1] > _COLLINEAR_TOL * scale:
                collinear = False
                break
            longest = vecs[np.argmax(np.linalg.norm(vecs, axis=1))]
            if np.linalg.norm(longest) > _COLLINEAR_TOL * scale:
                alpha[k] = np.arctan2(longest[1], longest[0])
        if not collinear:
            alpha[:] = 0.0
        self.layout = ParameterLayout(n_bodies=nb, collinear=collinear)
        self.direction_angles = alpha  # alpha_k: angle of body k's line u_k (collinear form)

        # S: dphi = S w, lower-triangular; the ee attitude rate is S[m] w
        S = np.zeros((nb, nb))
        S[:, 0] = 1.0
        for k in range(1, nb):
            S[k, 1 : k + 1] = g.axis_signs[:k]
        self.S = S
        self._ST = np.ascontiguousarray(S.T)
        # phi_k = S q + offset_k; offsets include the fixed joint yaws and alpha_k
        cum_yaw = np.concatenate(([0.0], np.cumsum(g.joint_yaws)))
        self._phi_offset = cum_yaw + alpha
        self._ee_angle_offset = cum_yaw[m] + g.ee_yaw
        self._ee_row = S[m].copy()

        self._K, self._L = (np.array(x, dtype=int) for x in np.triu_indices(nb, 1))
        self._P = len(self._K)
        Wl, Vl = self._line_vectors(W, V)
        V_body, theta_d = self._parameters(g, Wl, Vl)
        self.theta_d = read_only(theta_d)
        self._V_body = read_only(V_body)
        self.barycentric_W = read_only(Wl)
        self.barycentric_V = read_only(Vl)

        # column index helpers
        self._diag_cols = np.arange(nb)
        self._pc_cols = nb + np.arange(self._P)
        self._ps_cols = nb + self._P + np.arange(self._P)
        self._ar = np.arange(nb)
        self._memo: dict = {}

    def _line_vectors(self, W, V) -> tuple[np.ndarray, np.ndarray]:
        """W_ik and V_k rotated into each body's line frame (alpha_k; the identity for the
        general layout, where every alpha_k = 0)."""
        c, s = np.cos(self.direction_angles), np.sin(self.direction_angles)
        rot = np.stack((np.stack((c, s), -1), np.stack((-s, c), -1)), -2)  # (nb, 2, 2)
        return np.einsum("kde,ike->ikd", rot, W), np.einsum("kde,ke->kd", rot, V)

    def _parameters(self, g: PlanarGeometry, Wl, Vl) -> tuple[np.ndarray, np.ndarray]:
        """(V, theta_d) of Eqs. (4, 12) in this model's layout from line-frame vectors."""
        dc = np.einsum("i,ikd,ild->kl", g.masses, Wl, Wl) + np.diag(g.inertias)
        ds = np.einsum("i,ik,il->kl", g.masses, Wl[..., 0], Wl[..., 1])
        ds = ds - ds.T  # sum_i m_i (W_ik x W_il)
        theta_d = [np.diag(dc), dc[self._K, self._L]]
        if not self.layout.collinear:
            theta_d.append(ds[self._K, self._L])
        V_body = Vl[:, 0].copy() if self.layout.collinear else Vl.reshape(-1).copy()
        return V_body, np.concatenate(theta_d)

    def parameters_of(self, geometry: PlanarGeometry) -> tuple[np.ndarray, np.ndarray]:
        """(V, theta_d), the kinematic and dynamic parameters of Eqs. (4, 12), of another
        robot with this model's chain (joints and end effector) and the masses, CoMs and
        inertias of ``geometry``, written in this model's layout: the parameters a
        controller with this model has for that robot (e.g. drawn estimates,
        :mod:`ffsm_pin.sim.estimates`). A collinear layout needs every CoM of ``geometry`` on
        its body's line (ParameterError otherwise)."""
        _, W, V = barycentric_vectors(geometry, 2)
        if geometry.n_joints != self.n_joints or geometry.ee_body != self.geometry.ee_body:
            raise ParameterError("parameters_of: the geometry is not this model's chain")
        Wl, Vl = self._line_vectors(W, V)
        if self.layout.collinear:
            scale = max(1.0, float(np.abs(Wl).max()))
            off = max(float(np.abs(Wl[..., 1]).max()), float(np.abs(Vl[:, 1]).max()))
            if off > 1e-9 * scale:
                raise ParameterError(
                    f"parameters_of: a CoM is {off:.3g} m off its body's line; the collinear "
                    "layout (no Ds_kl) cannot hold these parameters"
                )
        return self._parameters(geometry, Wl, Vl)

    def kernel_constants(self) -> PlanarKernelConstants:
        """The constant arrays of this robot that the compiled kernels take."""
        return PlanarKernelConstants(
            self.S, self._phi_offset, self._K, self._L, self._ee_row, self.layout.collinear
        )

    # ------------------------------------------------------------------ configuration
    def body_angles(self, q_b, q_m) -> BodyAngles:
        """Trigonometry of one configuration, shared by every evaluator.

        The last few configurations are memoised, so that the evaluators called for one
        state (real, or complex for a complex step) compute it once.
        """
        q_m = np.asarray(q_m)
        if isinstance(q_b, np.ndarray):
            q_b = q_b.item()
        key = (q_b, q_m.tobytes(), q_m.dtype.char)
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        q = np.empty(self.n_joints + 1, dtype=np.result_type(q_b, q_m, float))
        q[0] = q_b
        q[1:] = q_m
        phi = self.S @ q + self._phi_offset
        c, s = np.cos(phi), np.sin(phi)
        if self.layout.collinear:
            pos = np.array([c, s])  # R(phi) e_x
            rate = np.array([-s, c])  # R(phi) J e_x
        else:
            nb = len(phi)
            pos = np.empty((2, 2 * nb), dtype=phi.dtype)
            rate = np.empty((2, 2 * nb), dtype=phi.dtype)
            pos[0, 0::2], pos[1, 0::2] = c, s  # R e_x
            pos[0, 1::2], pos[1, 1::2] = -s, c  # R e_y
            rate[0, 0::2], rate[1, 0::2] = -s, c  # R J e_x
            rate[0, 1::2], rate[1, 1::2] = -c, -s  # R J e_y
        # pair terms cos/sin(phi_l - phi_k) from the products (no second trig call)
        cK, sK, cL, sL = c[self._K], s[self._K], c[self._L], s[self._L]
        pair_c, pair_s = cL * cK + sL * sK, sL * cK - cL * sK
        out = BodyAngles(*(read_only(x) for x in (phi, pos, rate, pair_c, pair_s)))
        if len(self._memo) >= 4:
            self._memo.clear()
        self._memo[key] = out
        return out

    def angles(self, q_b: float, q_m) -> np.ndarray:
        """phi_k [rad], absolute angle of each body's line frame."""
        return self.body_angles(q_b, q_m).phi

    def ee_angle(self, q_b: float, q_m) -> float:
        """End-effector attitude q_e [rad] (unwrapped, follows q_b and q_m)."""
        return self._ee_row[0] * q_b + self._ee_row[1:] @ np.asarray(q_m) + self._ee_angle_offset

    def _expand_rates(self, dphi):
        return dphi if self.layout.collinear else np.repeat(dphi, 2)

    # ------------------------------------------------------------------ kinematics
    def ee_offset(self, theta_z, q_b: float, q_m) -> np.ndarray:
        """p_e - p_com [m] = sum_k R(phi_k) V_k."""
        theta_z = self._check(theta_z, self.n_z, "theta_z")
        return self.body_angles(q_b, q_m).pos @ theta_z[2:]

    def ee_pose(self, theta_z, q_b: float, q_m, com_position) -> np.ndarray:
        """z_e = (p_e, q_e) [m, m, rad] given the system CoM position [m]."""
        p = np.asarray(com_position, dtype=float) + self.ee_offset(theta_z, q_b, q_m)
        return np.array([p[0], p[1], self.ee_angle(q_b, q_m)])

    def jacobians(self, theta_z, q_b: float, q_m) -> tuple[np.ndarray, np.ndarray]:
        """J_b (3 x 1) and J_m (3 x n) of Eq. (3) for a parameter vector theta_z."""
        theta_z = self._check(theta_z, self.n_z, "theta_z")
        rate = self.body_angles(q_b, q_m).rate
        nb = self.n_joints + 1
        # d p_e / d phi_k = R(phi_k) J V_k ; chain rule with dphi = S w
        if self.layout.collinear:
            dp_dphi = rate * theta_z[2:]
        else:
            dp_dphi = (rate * theta_z[2:]).reshape(2, nb, 2).sum(axis=2)
        J = np.empty((3, nb), dtype=dp_dphi.dtype)
        J[:2] = dp_dphi @ self.S
        J[2] = self._ee_row
        return J[:, :1], J[:, 1:]

    def Y_z(self, q_b: float, q_m, w) -> np.ndarray:
        """Regressor of Eq. (4): J_b w_b + J_m w_m + v0bar = Y_z theta_z + (0, 0, dq_e/dt).

        Shape (3, n_z); the attitude row is zero (parameter-free, see
        :meth:`ee_attitude_rate`).
        """
        w = np.asarray(w, dtype=float)
        rate = self.body_angles(q_b, q_m).rate
        Y = np.zeros((3, self.n_z))
        Y[0, 0] = Y[1, 1] = 1.0
        Y[:2, 2:] = rate * self._expand_rates(self.S @ w)
        return Y

    def ee_attitude_rate(self, w) -> float:
        """dq_e/dt [rad/s], the parameter-free attitude row of Eq. (3)."""
        return float(self._ee_row @ np.asarray(w, dtype=float))

    # ------------------------------------------------------------------ dynamics
    def mass_matrix(self, theta_d, q_b: float, q_m) -> np.ndarray:
        """M(q, theta_d) of Eq. (9a), (n+1) x (n+1)."""
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

    def Y_M(self, q_b: float, q_m, a) -> np.ndarray:
        """Regressor of M(q) a: ``Y_M(q, a) theta_d = M(q, theta_d) a``. Shape (n+1, n_d)."""
        ba = self.body_angles(q_b, q_m)
        b = self.S @ np.asarray(a, dtype=float)
        Yp = np.zeros((self.n_joints + 1, self.n_d))
        Yp[self._ar, self._diag_cols] = b
        self._scatter(Yp, b, ba.c, -ba.s)
        return self._ST @ Yp

    def velocity_regressors(self, q_b: float, q_m, w, s_vec) -> tuple[np.ndarray, np.ndarray]:
        """(Y_Mdot(w, s), Y_h(w)) in one pass; see :meth:`Y_Mdot` and :meth:`Y_h`."""
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

    def Y_Mdot(self, q_b: float, q_m, w, s_vec) -> np.ndarray:
        """Regressor of dM/dt s along w: ``Y theta_d = (d/dt M(q(t), theta_d)) s``."""
        return self.velocity_regressors(q_b, q_m, w, s_vec)[0]

    def Y_h(self, q_b: float, q_m, w) -> np.ndarray:
        """Regressor of the velocity product: ``Y theta_d = C(q, w) w`` (Eq. 8)."""
        return self.velocity_regressors(q_b, q_m, w, np.zeros(self.n_joints + 1))[1]

    def Y_d(self, q_b: float, q_m, w, s1, s2) -> np.ndarray:
        """Eq. (12) with s3 = w: ``Y_d theta_d = M s1 - dM/dt s2 + C(q, w) w``."""
        Y_Mdot, Y_h = self.velocity_regressors(q_b, q_m, w, s2)
        return self.Y_M(q_b, q_m, s1) - Y_Mdot + Y_h

    def velocity_product(self, theta_d, q_b: float, q_m, w) -> np.ndarray:
        """C(q, w, theta_d) w."""
        return self.Y_h(q_b, q_m, w) @ self._check(theta_d, self.n_d, "theta_d")

    def mass_matrix_rate(self, theta_d, q_b: float, q_m, w) -> np.ndarray:
        """dM/dt (q, w, theta_d), (n+1) x (n+1), column j = Y_Mdot(e_j) theta_d."""
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        nb = self.n_joints + 1
        return np.column_stack([self.Y_Mdot(q_b, q_m, w, e) @ theta_d for e in np.eye(nb)])

    def reaction_torque(self, theta_d, q_b: float, q_m, w, w_dot) -> float:
        """Reaction torque of the manipulator on the base, Eqs. (6)-(7) [N m].

        ``F_r = M_bb dw_b/dt + C_bb w_b = -(M_bm dw_m/dt + C_bm w_m)`` with the Christoffel
        C, for which ``C_bb w_b = 1/2 dM_bb/dt w_b`` (M does not depend on q_b).
        ``w_dot`` = (dw_b/dt, dw_m/dt) [rad/s^2].
        """
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        e0 = np.zeros(self.n_joints + 1)
        e0[0] = 1.0
        M_bb = self.mass_matrix(theta_d, q_b, q_m)[0, 0]
        M_bb_dot = (self.Y_Mdot(q_b, q_m, w, e0) @ theta_d)[0]
        return float(M_bb * w_dot[0] + 0.5 * M_bb_dot * w[0])

    # ------------------------------------------------------------------ momentum
    def Y_b(self, q_b: float, q_m, w) -> np.ndarray:
        """Regressor of Eq. (14): ``Y_b theta_b = H_bb w_b + H_bm w_m - A_0``. Shape (1, n_b)."""
        Y = np.empty((1, self.n_b))
        Y[0, 0] = -1.0
        Y[0, 1:] = self.Y_M(q_b, q_m, w)[0]
        return Y

    def momentum_matrices(self, theta_b, q_b: float, q_m) -> tuple[np.ndarray, np.ndarray, float]:
        """(H_bb (1x1), H_bm (1 x n), A_0) of Eq. (13) from a parameter vector theta_b.

        H is the first row of M = S^T M_phi S, i.e. ``1^T M_phi S``. Like :meth:`angles`,
        :meth:`jacobians`, :meth:`ee_offset` and :meth:`mass_matrix`, this accepts complex
        arguments (used for complex-step derivatives).
        """
        theta_b = self._check(theta_b, self.n_b, "theta_b")
        row = self._mass_phi(theta_b[1:], self.body_angles(q_b, q_m)).sum(axis=0) @ self.S
        return row[None, :1], row[None, 1:], theta_b[0]


class BodyAngles(NamedTuple):
    """Trigonometry of one configuration (see :meth:`BarycentricModel.body_angles`)."""

    phi: np.ndarray  # phi_k [rad]
    pos: np.ndarray  # (2, n_V) R(phi_k) u, columns multiplying the V parameters
    rate: np.ndarray  # (2, n_V) R(phi_k) J u
    c: np.ndarray  # cos(phi_l - phi_k) for the pairs k < l
    s: np.ndarray  # sin(phi_l - phi_k)
