"""The spatial parametric model: 3-D barycentric vectors, theta_z, theta_d, theta_b, regressors.

Bodies k = 0..n (0 = base), R_k the rotation of body k (body to inertial), a_k the origin of
joint k+1 in body k, c_k the CoM, e the end effector in body m = ``ee_body``,
mu_k = m_k / m_total (docs/spatial.md section 2):

* ``G_ik = a_k (k < i), c_i (k = i), 0 (k > i)``, ``W_ik = G_ik - sum_j mu_j G_jk``,
  ``V_k = E_k - sum_j mu_j G_jk`` with ``E_k = a_k (k < m), e (k = m), 0 (k > m)``;
* ``p_e - p_com = sum_k R_k V_k``; body angular velocities ``w_k = S_k w`` with
  ``S_k = [E_3, z_1, ..., z_k, 0, ...]`` (z_j the inertial axis of joint j) and
  ``w = (w_b, dq_m)``, w_b the base angular velocity in the *inertial* frame;
* reduced kinetic energy (docs/spatial.md section 3), with ``D_kl = sum_i m_i W_ik W_il^T``
  and ``Jbar_k = I_k + tr(D_kk) E_3 - D_kk``::

      T = 1/2 sum_k w_k^T R_k Jbar_k R_k^T w_k
          + sum_{k<l} [ (w_k . w_l) tr(R_k D_kl R_l^T) - w_l^T R_k D_kl R_l^T w_k ]

  so ``M = sum_k S_k^T R_k Jbar_k R_k^T S_k + sum_{k<l} (S_k^T K_kl S_l + S_l^T K_kl^T S_k)``,
  ``K_kl = tr(R_k D_kl R_l^T) E_3 - R_l D_kl^T R_k^T`` (Eq. 9a).

Parameter vectors (sizes for n joints):

* ``theta_z = col(v_0, V_0, ..., V_n)`` (Eq. 4), 3 + 3(n+1), each V_k in body k's frame;
* ``theta_d = (Jbar_0..Jbar_n as (xx, xy, xz, yy, yz, zz), D_kl for k<l row-major 3x3)``
  (Eq. 12), 6(n+1) + 9 n(n+1)/2;
* ``theta_b = col(A_0, theta_d)`` (Eq. 14), A_0 the angular momentum about the CoM.

The end-effector attitude rows of Eq. (3) (MRP rate ``1/4 B(q_e) R_e^T w_e``) carry no
parameter; they are known terms (``Y_z`` has zero attitude rows, as in the planar model).

Derivatives along the motion (``dM/dt s``) and with respect to the joint angles (``dT/dq_m``
in ``C w``, docs/spatial.md section 4) are taken exactly by forward-mode differentiation of the
same bilinear expressions: the tangents of R_k and z_j are closed-form (``dR_k = [w_k]x R_k``,
``dz_j = w_j x z_j``; ``dR_k/dq_j = [z_j]x R_k`` for k >= j) and are carried as the imaginary
part of a complex step, which for these polynomial expressions is exact to rounding (numpy
reference); the compiled kernels carry the same tangents as (value, tangent) pairs in real
arithmetic (:func:`ffsm_pin.model._spatial_velocity_kernels.velocity_terms`).

This module holds the model class; its pieces, by concern:

* :mod:`._spatial_layout`: the parameter vectors' sizes and entry names
  (:class:`~._spatial_layout.SpatialParameterLayout`);
* :mod:`._spatial_reference`: the vectorised numpy reference (S_k, the tangents, the bilinear
  cores), a base class of the model;
* :mod:`._spatial_dynamics`: M, dM/dt, C w, F_r, the momentum matrices and the regressors
  Y_M, Y_Mdot, Y_h, Y_T, Y_d, Y_b (:class:`~._spatial_dynamics.SpatialDynamics`, the model's
  base class, on :class:`~._spatial_reference.SpatialReference`);
* :mod:`._spatial_terms`: one controller period's terms (:class:`~._spatial_terms.ControllerTerms`)
  and their compiled all-in-one call;
* the compiled (numba) kernels: :mod:`._spatial_kinematics_kernels` (rotations, J, Y_z, the
  attitude rows), :mod:`._spatial_mass_kernels` (M, Y_M) and :mod:`._spatial_velocity_kernels`
  (Y_Mdot, Y_h).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from typing_extensions import override

from .._arrays import read_only
from .._docstrings import doc_entries, fill_doc
from ..attitude import mrp
from ..errors import ParameterError
from ..robot import SpatialGeometry
from . import _spatial_kinematics_kernels as kkin
from . import _spatial_terms as kterms
from ._common import barycentric_vectors
from ._spatial_dynamics import SpatialDynamics
from ._spatial_layout import SYM6, SpatialParameterLayout
from ._spatial_reference import Kinematics, skew_batch
from ._spatial_terms import ControllerTerms, TermsBuffers

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    q_b_complex="""
        q_b : ndarray, shape (3,)
            Base attitude, MRP; may be complex.""",
    q_m_complex="""
        q_m : ndarray, shape (n,)
            Joint angles [rad]; may be complex.""",
    q_b="""
        q_b : ndarray, shape (3,)
            Base attitude, MRP.""",
    q_m="""
        q_m : ndarray, shape (n,)
            Joint angles [rad].""",
    w="""
        w : ndarray, shape (n + 3,)
            (w_b, w_m) [rad/s], w_b in the inertial frame.""",
    params_q_complex=("q_b_complex", "q_m_complex"),
    params_q=("q_b", "q_m"),
    params_w_q=("w", "q_b", "q_m"),
)


class SpatialKernelConstants(NamedTuple):
    """The arrays the compiled spatial kernels take for a robot (``control/fast_spatial.py``);
    its type selects the spatial steps of the one compiled period (``control/period.py``)."""

    joint_rot: np.ndarray  # (n, 3, 3) joint placements' rotations, contiguous
    axes: np.ndarray  # (n, 3) joint axes, contiguous
    ee_rot: np.ndarray  # (3, 3) end-effector frame in its body, contiguous
    ee_body: int  # body carrying the end effector (1..n)


@fill_doc(_DOC)
class SpatialBarycentricModel(SpatialDynamics):
    """The reduced, parametric free-floating model of a spatial serial chain.

    Configuration arguments: ``q_b`` the base attitude as an MRP 3-vector, ``q_m`` the joint
    angles [rad]; velocity arguments ``w = (w_b, w_m)`` [rad/s] with w_b in the inertial frame.
    Method names and argument order are those of the planar
    :class:`ffsm_pin.model.planar.BarycentricModel` (the shared interface is
    :class:`ffsm_pin.model.interface.ReducedModel`).

    ``backend="numba"`` (default) evaluates real arguments with the compiled kernels
    (:mod:`ffsm_pin.model._spatial_kinematics_kernels`,
    :mod:`~ffsm_pin.model._spatial_mass_kernels`,
    :mod:`~ffsm_pin.model._spatial_velocity_kernels`, :mod:`~ffsm_pin.model._spatial_terms`);
    ``"numpy"`` uses the vectorised numpy reference
    (:class:`~ffsm_pin.model._spatial_reference.SpatialReference`, also used for complex
    arguments).

    Parameters
    ----------
    geometry : SpatialGeometry
        The chain (n joints): masses, CoMs, inertias, joints and end effector, in body frames.
    backend : {"numba", "numpy"}, optional
        The evaluator of real arguments (ParameterError for another).
    """

    m2 = 3  # end-effector position components
    m3 = 3  # attitude components (MRP)

    def __init__(self, geometry: SpatialGeometry, *, backend: str = "numba"):
        if backend not in ("numba", "numpy"):
            raise ParameterError(f"backend {backend!r} is not one of 'numba', 'numpy'")
        self.backend = backend
        self._numba = backend == "numba"
        g = geometry
        n = g.n_joints
        nb = n + 1
        self.geometry = g
        self.n_joints = n
        self.layout = SpatialParameterLayout(n_bodies=nb)
        _, W, V = barycentric_vectors(g, 3)
        self._K, self._L = (np.array(x, dtype=int) for x in np.triu_indices(nb, 1))
        self._P = len(self._K)
        self.theta_d = read_only(self._theta_d(g, W))
        self.barycentric_W = read_only(W)
        self.barycentric_V = read_only(V)
        self._V_body = read_only(V.ravel().copy())
        self._nb, self._N = nb, n + 3
        self._joint_rot = np.array(g.joint_rotations)
        self._axes = np.array(g.axes)
        self._ee_rot = np.array(g.ee_rotation)
        # pattern of S: S[k, :, 3 + j] = z_j for joints j (0-based) with j < k
        self._smask = (np.arange(n)[None, :] < np.arange(nb)[:, None]).astype(float)
        # dR_k/dq_j nonzero for bodies k >= j + 1 (0-based joint j); dz_i/dq_j for i > j
        self._below = (np.arange(nb)[None, :] >= np.arange(1, n + 1)[:, None]).astype(float)
        self._after = (np.arange(n)[None, :] > np.arange(n)[:, None]).astype(float)
        self._memo: dict = {}
        self._memo_fast: dict = {}
        self._joint_rot_c = np.ascontiguousarray(self._joint_rot, dtype=float)
        self._axes_c = np.ascontiguousarray(self._axes, dtype=float)
        self._ee_rot_c = np.ascontiguousarray(self._ee_rot, dtype=float)
        self._Vc = np.ascontiguousarray(V, dtype=float)
        self._nd, self._nz, self._ee_body = self.layout.n_d, self.layout.n_z, g.ee_body

    def _theta_d(self, g: SpatialGeometry, W: np.ndarray) -> np.ndarray:
        """theta_d of Eq. (12) from the masses and inertias of ``g`` and its vectors W."""
        nb = self.layout.n_bodies
        D = np.einsum("i,ikx,ily->klxy", g.masses, W, W)  # D_kl = sum_i m_i W_ik W_il^T
        Jbar = (
            g.inertias
            + np.trace(D[np.arange(nb), np.arange(nb)], axis1=1, axis2=2)[:, None, None] * np.eye(3)
            - D[np.arange(nb), np.arange(nb)]
        )
        rows, cols = zip(*SYM6, strict=True)
        return np.concatenate((Jbar[:, rows, cols].ravel(), D[self._K, self._L].reshape(-1)))

    def parameters_of(self, geometry: SpatialGeometry) -> tuple[np.ndarray, np.ndarray]:
        """(V, theta_d), the kinematic and dynamic parameters of Eqs. (4, 12), of another
        robot with this model's chain (joints and end effector) and the masses, CoMs and
        inertias of ``geometry``: the parameters a controller with this model has for that
        robot (e.g. drawn estimates, :mod:`ffsm_pin.sim.estimates`)."""
        if geometry.n_joints != self.n_joints or geometry.ee_body != self.geometry.ee_body:
            raise ParameterError("parameters_of: the geometry is not this model's chain")
        _, W, V = barycentric_vectors(geometry, 3)
        return V.ravel().copy(), self._theta_d(geometry, W)

    def kernel_constants(self) -> SpatialKernelConstants:
        """The constant arrays of this robot that the compiled kernels take."""
        return SpatialKernelConstants(
            self._joint_rot_c, self._axes_c, self._ee_rot_c, int(self.geometry.ee_body)
        )

    # ------------------------------------------------------------------ configuration
    def kinematics(self, q_b, q_m) -> Kinematics:
        """Body rotations R_k, joint axes z_j and S_k for one configuration (memoised; real or
        complex arguments).

        %(params_q_complex)s

        Returns
        -------
        Kinematics
            R (n+1, 3, 3) body to inertial, z (n, 3) inertial joint axes, S (n+1, 3, n+3)
            with w_k = S_k w.
        """
        q_b = np.asarray(q_b)
        q_m = np.asarray(q_m)
        key = (q_b.tobytes(), q_m.tobytes(), q_b.dtype.char, q_m.dtype.char)
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        dtype = np.result_type(q_b, q_m, float)
        nb = self._nb
        R = np.empty((nb, 3, 3), dtype=dtype)
        R[0] = mrp.to_rotation(q_b)
        c, s = np.cos(q_m), np.sin(q_m)
        U = skew_batch(self._axes)
        # Rodrigues: rot(u, q) = E + sin q [u]x + (1 - cos q) [u]x^2
        rot = (
            np.eye(3)
            + s[:, None, None] * U
            + (1 - c)[:, None, None] * np.einsum("jxy,jyz->jxz", U, U)
        )
        for k in range(1, nb):
            R[k] = R[k - 1] @ self._joint_rot[k - 1] @ rot[k - 1]
        z = np.einsum("jxy,jy->jx", R[1:], self._axes)
        out = Kinematics(R, z, self._s_matrix(z))
        if len(self._memo) >= 4:
            self._memo.clear()
        self._memo[key] = out
        return out

    def _use_fast(self, *args) -> bool:
        if not self._numba:
            return False
        for x in args:  # the dtype test first: np.iscomplexobj costs more per call
            if (x.dtype.kind == "c") if isinstance(x, np.ndarray) else np.iscomplexobj(x):
                return False
        return True

    def _rz(self, q_b, q_m):
        """(R, z) from the compiled kinematics (real arguments), memoised like kinematics()."""
        q_b = np.ascontiguousarray(q_b, dtype=float)
        q_m = np.ascontiguousarray(q_m, dtype=float)
        key = (q_b.tobytes(), q_m.tobytes())
        hit = self._memo_fast.get(key)
        if hit is not None:
            return hit
        R = np.empty((self._nb, 3, 3))
        z = np.empty((self.n_joints, 3))
        kkin.kinematics(q_b, q_m, self._joint_rot_c, self._axes_c, R, z)
        if len(self._memo_fast) >= 4:
            self._memo_fast.clear()
        self._memo_fast[key] = (R, z)
        return R, z

    # ------------------------------------------------------------------ kinematics
    @override
    def ee_offset(self, theta_z, q_b, q_m) -> np.ndarray:
        # p_e - p_com [m] = sum_k R_k V_k (inertial frame).
        theta_z = self._check(theta_z, self.n_z, "theta_z")
        R = self.kinematics(q_b, q_m).R
        return np.einsum("kxy,ky->x", R, theta_z[3:].reshape(self._nb, 3))

    def ee_rotation(self, q_b, q_m) -> np.ndarray:
        """R_e, the end-effector frame's rotation (body to inertial); parameter-free.

        %(params_q_complex)s

        Returns
        -------
        ndarray, shape (3, 3)
            R_e, end-effector frame to inertial.
        """
        return self.kinematics(q_b, q_m).R[self.geometry.ee_body] @ self._ee_rot

    def ee_attitude(self, q_b, q_m) -> np.ndarray:
        """q_e, the end-effector attitude as an MRP on the |s| <= 1 branch.

        %(params_q)s

        Returns
        -------
        ndarray, shape (3,)
            q_e, MRP of R_e.
        """
        return mrp.from_rotation(self.ee_rotation(q_b, q_m))

    @override
    def ee_pose(self, theta_z, q_b, q_m, com_position) -> np.ndarray:
        # z_e = (p_e, q_e) [m, MRP] given the system CoM position [m].
        p = np.asarray(com_position) + self.ee_offset(theta_z, q_b, q_m)
        return np.concatenate((p, self.ee_attitude(q_b, q_m)))

    def _attitude_rows(self, kin: Kinematics, q_b, q_m):
        R_e = kin.R[self.geometry.ee_body] @ self._ee_rot
        q_e = mrp.from_rotation(R_e)  # analytic: complex steps pass through
        return mrp.L_matrix(q_e, R_e) @ kin.S[self.geometry.ee_body]

    @override
    def jacobians(self, theta_z, q_b, q_m) -> tuple[np.ndarray, np.ndarray]:
        # J_b (6 x 3) and J_m (6 x n) of Eq. (3) for a parameter vector theta_z.
        # Rows 1-3: d(p_e - p_com)/dt = -sum_k [R_k V_k]x S_k w; rows 4-6: the MRP rate 1/4
        # B(q_e) R_e^T S_m w (parameter-free).
        theta_z = self._check(theta_z, self.n_z, "theta_z")
        if self._use_fast(theta_z, q_b, q_m):
            R, z = self._rz(q_b, q_m)
            J = np.empty((6, self._N))
            V = np.ascontiguousarray(theta_z[3:].reshape(self._nb, 3))
            kkin.position_jacobian(R, z, V, J[:3])
            m = self.geometry.ee_body
            kkin.attitude_rows(R[m], self._ee_rot_c, z, m, J[3:])
            return J[:, :3], J[:, 3:]
        kin = self.kinematics(q_b, q_m)
        r = np.einsum("kxy,ky->kx", kin.R, theta_z[3:].reshape(self._nb, 3))
        J = np.empty((6, self._N), dtype=np.result_type(r, kin.S))
        J[:3] = -np.einsum("kxy,kyn->xn", skew_batch(r), kin.S)
        J[3:] = self._attitude_rows(kin, q_b, q_m)
        return J[:, :3], J[:, 3:]

    @override
    def Y_z(self, q_b, q_m, w) -> np.ndarray:
        # Regressor of Eq. (4): J_b w_b + J_m w_m + v0bar = Y_z theta_z + (0_3, dq_e/dt).
        # Shape (6, n_z); the attitude rows are zero (see :meth:`ee_attitude_rate`).
        if self._use_fast(q_b, q_m, w):
            R, z = self._rz(q_b, q_m)
            Y = np.zeros((6, self.n_z))
            kkin.y_z(R, z, np.ascontiguousarray(w, dtype=float), Y[:3])
            return Y
        kin = self.kinematics(q_b, q_m)
        om = kin.S @ np.asarray(w, dtype=float)
        Y = np.zeros((6, self.n_z))
        Y[:3, :3] = np.eye(3)
        Y[:3, 3:] = np.swapaxes(skew_batch(om) @ kin.R, 0, 1).reshape(3, -1)
        return Y

    def ee_attitude_rate(self, w, q_b, q_m) -> np.ndarray:
        """dq_e/dt [1/s], the parameter-free MRP rate of the end effector (rows 4-6 of Eq. 3).

        %(params_w_q)s

        Returns
        -------
        ndarray, shape (3,)
            dq_e/dt = 1/4 B(q_e) R_e^T w_e [1/s].
        """
        kin = self.kinematics(q_b, q_m)
        return self._attitude_rows(kin, q_b, q_m) @ np.asarray(w, dtype=float)

    # ------------------------------------------------------------------ controller terms
    def controller_terms(self, theta_z, theta_d, q_b, q_m, w, a, s_vec) -> ControllerTerms:
        """J_b, J_m (theta_z), Y_z(w), Y_b(w), Y_M(a), Y_Mdot(w, s), Y_h(w) and M(theta_d) for
        one configuration: the same values as the separate methods, in one compiled call
        (numba backend) or by calling them (numpy backend, complex arguments).

        Parameters
        ----------
        theta_z : array_like, shape (n_z,)
            Kinematic parameters (Eq. 4).
        theta_d : array_like, shape (n_d,)
            Dynamic parameters (Eq. 12).
        %(q_b)s
        %(q_m)s
        %(w)s
        a : ndarray, shape (n + 3,)
            The vector of Y_M(a).
        s_vec : ndarray, shape (n + 3,)
            The vector s of Y_Mdot(w, s).

        Returns
        -------
        ControllerTerms
            J_b (6, 3), J_m (6, n), Y_z (6, n_z), Y_b (3, n_b), Y_M, Y_Mdot, Y_h (n+3, n_d) and
            M (n+3, n+3).
        """
        theta_z = self._check(theta_z, self.n_z, "theta_z")
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        if not self._use_fast(theta_z, theta_d, q_b, q_m, w, a, s_vec):
            J_b, J_m = self.jacobians(theta_z, q_b, q_m)
            Y_Mdot, Y_h = self.velocity_regressors(q_b, q_m, w, s_vec)
            return ControllerTerms(
                J_b, J_m, self.Y_z(q_b, q_m, w), self.Y_b(q_b, q_m, w), self.Y_M(q_b, q_m, a),
                Y_Mdot, Y_h, self.mass_matrix(theta_d, q_b, q_m),
            )  # fmt: skip
        N, nd = self._N, self._nd
        J = np.empty((6, N))
        Yz = np.empty((6, self._nz))
        Yb = np.empty((3, self._nd + 3))
        YM = np.empty((N, nd))
        YMdot = np.empty((N, nd))
        Yh = np.empty((N, nd))
        M = np.empty((N, N))
        kterms.controller_terms(
            self.kernel_constants(), np.ascontiguousarray(q_b, dtype=float),
            np.ascontiguousarray(q_m, dtype=float), np.ascontiguousarray(theta_z, dtype=float),
            np.ascontiguousarray(theta_d, dtype=float), np.ascontiguousarray(w, dtype=float),
            np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(s_vec, dtype=float),
            TermsBuffers(J, Yz, Yb, YM, YMdot, Yh, M),
        )  # fmt: skip
        return ControllerTerms(J[:, :3], J[:, 3:], Yz, Yb, YM, YMdot, Yh, M)
