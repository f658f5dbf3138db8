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
from typing_extensions import override

from .._arrays import read_only
from .._docstrings import doc_entries, fill_doc
from ..errors import ParameterError
from ..robot import PlanarGeometry
from ._common import barycentric_vectors
from ._planar_dynamics import BodyAngles, PlanarDynamics
from ._pseudo_inertia import PseudoInertiaTable, planar_table

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    q_b="""
        q_b : float
            Base angle [rad].""",
    q_m="""
        q_m : ndarray, shape (n,)
            Joint angles [rad].""",
    params_q_b_q_m=("q_b", "q_m"),
)

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

    def pseudo_inertia_table(self) -> PseudoInertiaTable:
        """The map theta_d -> P (:func:`._pseudo_inertia.planar_table`)."""
        return planar_table(self.n_bodies, self.collinear)

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


@fill_doc(_DOC)
class BarycentricModel(PlanarDynamics):
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
        self._ee_row_base = float(S[m][0])  # its parts, for ee_angle each step
        self._ee_row_joints = self._ee_row[1:]  # (a view: the row is kept once)

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

        Parameters
        ----------
        q_b : float
            Base angle [rad]; may be complex.
        q_m : ndarray, shape (n,)
            Joint angles [rad]; may be complex.

        Returns
        -------
        BodyAngles
            The trigonometry of the configuration.
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
        """phi_k [rad], absolute angle of each body's line frame.

        %(params_q_b_q_m)s

        Returns
        -------
        ndarray, shape (n + 1,)
            phi_k [rad].
        """
        return self.body_angles(q_b, q_m).phi

    def ee_angle(self, q_b: float, q_m) -> float:
        """End-effector attitude q_e [rad] (unwrapped, follows q_b and q_m).

        %(params_q_b_q_m)s

        Returns
        -------
        float
            q_e [rad].
        """
        # (ndarray.dot: the same BLAS ddot as ``@`` on two vectors, at half its cost without
        # the matmul ufunc's dispatch: 0.4 us of a planar measurement's 3.5)
        joints = self._ee_row_joints.dot(np.asarray(q_m))
        return self._ee_row_base * q_b + joints + self._ee_angle_offset

    def _expand_rates(self, dphi):
        return dphi if self.layout.collinear else np.repeat(dphi, 2)

    # ------------------------------------------------------------------ kinematics
    @override
    def ee_offset(self, theta_z, q_b: float, q_m) -> np.ndarray:
        # p_e - p_com [m] = sum_k R(phi_k) V_k.
        theta_z = self._check(theta_z, self.n_z, "theta_z")
        return self.body_angles(q_b, q_m).pos @ theta_z[2:]

    @override
    def ee_pose(self, theta_z, q_b: float, q_m, com_position) -> np.ndarray:
        # z_e = (p_e, q_e) [m, m, rad] given the system CoM position [m].
        p = np.asarray(com_position, dtype=float) + self.ee_offset(theta_z, q_b, q_m)
        return np.array([p[0], p[1], self.ee_angle(q_b, q_m)])

    @override
    def jacobians(self, theta_z, q_b: float, q_m) -> tuple[np.ndarray, np.ndarray]:
        # J_b (3 x 1) and J_m (3 x n) of Eq. (3) for a parameter vector theta_z.
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

    @override
    def Y_z(self, q_b: float, q_m, w) -> np.ndarray:
        # Regressor of Eq. (4): J_b w_b + J_m w_m + v0bar = Y_z theta_z + (0, 0, dq_e/dt).
        # Shape (3, n_z); the attitude row is zero (parameter-free, see
        # :meth:`ee_attitude_rate`).
        w = np.asarray(w, dtype=float)
        rate = self.body_angles(q_b, q_m).rate
        Y = np.zeros((3, self.n_z))
        Y[0, 0] = Y[1, 1] = 1.0
        Y[:2, 2:] = rate * self._expand_rates(self.S @ w)
        return Y

    def ee_attitude_rate(self, w) -> float:
        """dq_e/dt [rad/s], the parameter-free attitude row of Eq. (3)."""
        return float(self._ee_row @ np.asarray(w, dtype=float))
