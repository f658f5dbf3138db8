"""The interface shared by the planar and the spatial reduced models.

The paper writes one theory over m2 (end-effector position components) and m3 (attitude
components): m2 = 2, m3 = 1 for planar robots (:class:`ffsm_pin.model.planar.BarycentricModel`)
and m2 = m3 = 3 for spatial robots with attitudes as modified Rodrigues parameters
(:class:`ffsm_pin.model.spatial.SpatialBarycentricModel`). The controller, the plant and
the recorder are written once against :class:`ReducedModel`.

Conventions: ``q_b`` is the base attitude (planar: an angle [rad]; spatial: an MRP 3-vector),
``q_m`` the joint angles [rad] (m1 of them), ``w = (w_b, w_m)`` the velocity (m3 + m1) with
w_b the base angular velocity in the inertial frame [rad/s]. Matrices are read-only or fresh
arrays. Sizes: n_z = len(theta_z), n_d = len(theta_d), n_b = len(theta_b) = m3 + n_d.
Equation numbers are the paper's (docs/model.md, docs/spatial.md).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from .._docstrings import doc_entries, fill_doc

# the Parameters entries the methods share (ffsm_pin._docstrings); the planar and spatial
# models inherit these docstrings (they derive from ReducedModel)
_DOC = doc_entries(
    theta_d="""
        theta_d : array_like, shape (n_d,)
            Dynamic parameters.""",
    theta_z="""
        theta_z : array_like, shape (n_z,)
            Kinematic parameters.""",
    q="""
        q_b : float or ndarray
            Base attitude [rad] (planar) or MRP (spatial).
        q_m : ndarray, shape (m1,)
            Joint angles [rad].""",
    q_w="""
        %(q)s
        w : ndarray, shape (m3 + m1,)
            (w_b, w_m) [rad/s].""",
    params_q=("q",),
    params_q_w=("q_w",),
    params_theta_z_q=("theta_z", "q"),
    params_theta_d_q=("theta_d", "q"),
    params_theta_d_q_w=("theta_d", "q_w"),
    s_vec="""
        s_vec : ndarray, shape (m3 + m1,)
            The vector dM/dt multiplies.""",
)


@runtime_checkable
@fill_doc(_DOC)
class ReducedModel(Protocol):
    """Parametric reduced model of a free-floating manipulator (Eqs. 3, 4, 8, 9a, 12-14)."""

    m2: int  # end-effector position components (2 planar, 3 spatial)
    m3: int  # attitude components (1 planar, 3 spatial)
    n_joints: int  # m1
    theta_d: np.ndarray  # true dynamic parameters (Eq. 12)

    @property
    def n_z(self) -> int:
        """n_1 = len(theta_z) (Eq. 4)."""
        ...

    @property
    def n_d(self) -> int:
        """n_2 = len(theta_d) (Eq. 12)."""
        ...

    @property
    def n_b(self) -> int:
        """n_3 = len(theta_b) = m3 + n_d (Eq. 14)."""
        ...

    def true_theta_z(self, com_velocity) -> np.ndarray:
        """theta_z = col(v_0, V_0..V_n) for the CoM velocity v_0 (m2) [m/s] (Eq. 4)."""
        ...

    def true_theta_b(self, angular_momentum) -> np.ndarray:
        """theta_b = col(A_0, theta_d), A_0 (m3) about the CoM [kg m^2/s] (Eq. 14)."""
        ...

    def parameters_of(self, geometry: Any) -> tuple[np.ndarray, np.ndarray]:
        """(V_0..V_n, theta_d) of Eqs. (4, 12) for the masses, CoMs and inertias of
        ``geometry`` (a geometry of the same chain), in this model's layout."""
        ...

    def ee_offset(self, theta_z, q_b: Any, q_m) -> np.ndarray:
        """p_e - p_com (m2) [m], inertial frame.

        %(params_theta_z_q)s

        Returns
        -------
        ndarray, shape (m2,)
            p_e - p_com [m].
        """
        ...

    def ee_pose(self, theta_z, q_b: Any, q_m, com_position) -> np.ndarray:
        """z_e = (p_e, q_e) (m2 + m3) [m, rad or MRP] for the system CoM position [m].

        %(params_theta_z_q)s
        com_position : array_like, shape (m2,)
            The system's CoM position [m].

        Returns
        -------
        ndarray, shape (m2 + m3,)
            z_e = (p_e, q_e).
        """
        ...

    def jacobians(self, theta_z, q_b: Any, q_m) -> tuple[np.ndarray, np.ndarray]:
        """(J_b ((m2+m3) x m3), J_m ((m2+m3) x m1)) of Eq. (3); attitude rows parameter-free.

        %(params_theta_z_q)s

        Returns
        -------
        J_b : ndarray, shape (m2 + m3, m3)
            Base Jacobian.
        J_m : ndarray, shape (m2 + m3, m1)
            Manipulator Jacobian.
        """
        ...

    def Y_z(self, q_b: Any, q_m, w) -> np.ndarray:
        """((m2+m3) x n_z): J_b w_b + J_m w_m + v0bar = Y_z theta_z + (0, dq_e/dt), Eq. (4);
        the attitude rows are zero.

        %(params_q_w)s

        Returns
        -------
        ndarray, shape (m2 + m3, n_z)
            Y_z.
        """
        ...

    def mass_matrix(self, theta_d, q_b: Any, q_m) -> np.ndarray:
        """M(q, theta_d), (m3+m1) square, Eq. (9a) [kg m^2].

        %(params_theta_d_q)s

        Returns
        -------
        ndarray, shape (m3 + m1, m3 + m1)
            M [kg m^2].
        """
        ...

    def mass_matrix_rate(self, theta_d, q_b: Any, q_m, w) -> np.ndarray:
        """dM/dt along w, (m3+m1) square [kg m^2/s].

        %(params_theta_d_q_w)s

        Returns
        -------
        ndarray, shape (m3 + m1, m3 + m1)
            dM/dt [kg m^2/s].
        """
        ...

    def Y_M(self, q_b: Any, q_m, a) -> np.ndarray:
        """((m3+m1) x n_d): Y_M theta_d = M a.

        %(params_q)s
        a : ndarray, shape (m3 + m1,)
            The vector M multiplies.

        Returns
        -------
        ndarray, shape (m3 + m1, n_d)
            Y_M(q, a).
        """
        ...

    def Y_Mdot(self, q_b: Any, q_m, w, s_vec) -> np.ndarray:
        """((m3+m1) x n_d): Y theta_d = dM/dt s along w.

        %(params_q)s
        w : ndarray, shape (m3 + m1,)
            (w_b, w_m) [rad/s], the motion along which dM/dt is taken.
        %(s_vec)s

        Returns
        -------
        ndarray, shape (m3 + m1, n_d)
            The regressor.
        """
        ...

    def Y_h(self, q_b: Any, q_m, w) -> np.ndarray:
        """((m3+m1) x n_d): Y theta_d = C(q, w) w, Eq. (8).

        %(params_q_w)s

        Returns
        -------
        ndarray, shape (m3 + m1, n_d)
            Y_h.
        """
        ...

    def velocity_regressors(self, q_b: Any, q_m, w, s_vec) -> tuple[np.ndarray, np.ndarray]:
        """(Y_Mdot(w, s), Y_h(w)) in one pass.

        %(params_q_w)s
        %(s_vec)s

        Returns
        -------
        Y_Mdot, Y_h : ndarray, shape (m3 + m1, n_d)
            The two regressors.
        """
        ...

    def Y_d(self, q_b: Any, q_m, w, s1, s2) -> np.ndarray:
        """Eq. (12) with s3 = w: Y_d theta_d = M s1 - dM/dt s2 + C w.

        %(params_q_w)s
        s1, s2 : ndarray, shape (m3 + m1,)
            The vectors of Eq. (12).

        Returns
        -------
        ndarray, shape (m3 + m1, n_d)
            Y_d.
        """
        ...

    def velocity_product(self, theta_d, q_b: Any, q_m, w) -> np.ndarray:
        """C(q, w, theta_d) w (m3+m1) [N m], Eq. (8).

        %(params_theta_d_q_w)s

        Returns
        -------
        ndarray, shape (m3 + m1,)
            C w [N m].
        """
        ...

    def reaction_torque(self, theta_d, q_b: Any, q_m, w, w_dot) -> Any:
        """F_r of Eqs. (6)-(7) [N m] (float planar, 3-vector spatial).

        %(params_theta_d_q_w)s
        w_dot : ndarray, shape (m3 + m1,)
            (dw_b/dt, dw_m/dt) [rad/s^2].

        Returns
        -------
        float or ndarray
            F_r [N m].
        """
        ...

    def Y_b(self, q_b: Any, q_m, w) -> np.ndarray:
        """(m3 x n_b): Y_b theta_b = H_bb w_b + H_bm w_m - A_0, Eq. (14).

        %(params_q_w)s

        Returns
        -------
        ndarray, shape (m3, n_b)
            Y_b.
        """
        ...

    def momentum_matrices(self, theta_b, q_b: Any, q_m) -> tuple[np.ndarray, np.ndarray, Any]:
        """(H_bb (m3 x m3), H_bm (m3 x m1), A_0) of Eq. (13).

        Parameters
        ----------
        theta_b : array_like, shape (n_b,)
            Momentum parameters.
        %(q)s

        Returns
        -------
        H_bb : ndarray, shape (m3, m3)
            Base inertia.
        H_bm : ndarray, shape (m3, m1)
            Coupling inertia.
        A_0 : float or ndarray
            A_0 of Eq. (13).
        """
        ...

    def kernel_constants(self) -> Any:
        """The constant arrays the compiled kernels of :mod:`ffsm_pin.control` take."""
        ...
