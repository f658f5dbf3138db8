"""What the planar and the spatial barycentric models share: the chain's barycentric vectors,
sizes of the parameter vectors, the true theta_z and theta_b of a state, and the check of a
parameter vector's shape."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from .._arrays import read_only
from ..errors import ParameterError
from ._pseudo_inertia import PseudoInertiaTable, pseudo_inertia
from .interface import ReducedModel


class BarycentricVectors(NamedTuple):
    """A chain's vectors in body coordinates [m], ``dim`` = 2 (planar) or 3 per vector."""

    child_joints: np.ndarray  # (nb, dim) a_k: body k's child joint, zero for the last body
    W: np.ndarray  # (nb, nb, dim) W_ik = G_ik - sum_j mu_j G_jk (G_ik: body i's CoM along k)
    V: np.ndarray  # (nb, dim) V_k = E_k - sum_j mu_j G_jk (E: the end-effector along the chain)


def barycentric_vectors(g: Any, dim: int) -> BarycentricVectors:
    """The barycentric vectors of a chain's geometry ``g`` (a planar or spatial geometry:
    masses, CoMs, child joints and the end-effector in body coordinates), mu_j = m_j / m."""
    n = g.n_joints
    nb = n + 1
    mu = g.masses / g.total_mass
    a = np.zeros((nb, dim))
    a[:n] = g.child_joints
    G = np.zeros((nb, nb, dim))  # G[i, k]: body i's CoM written along the chain
    for i in range(nb):
        G[i, :i] = a[:i]
        G[i, i] = g.coms[i]
    Gbar = np.einsum("j,jkd->kd", mu, G)
    E = np.zeros((nb, dim))
    m = g.ee_body
    E[:m] = a[:m]
    E[m] = g.ee_position
    return BarycentricVectors(a, G - Gbar[None], E - Gbar)


class BarycentricCommon(ReducedModel):
    """Base of :class:`~ffsm_pin.model.planar.BarycentricModel` and
    :class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`; the methods of
    :class:`~ffsm_pin.model.interface.ReducedModel` they implement take its docstrings."""

    m2: int  # end-effector position components
    m3: int  # attitude components
    layout: Any  # the model's parameter layout (n_z, n_d, n_b)
    theta_d: np.ndarray  # the true dynamic parameters (Eq. 12)
    _V_body: np.ndarray  # the true kinematic parameters V_k of Eq. (4)

    @property
    def n_z(self) -> int:
        """n_1 = len(theta_z) (Eq. 4)."""
        return self.layout.n_z

    @property
    def n_d(self) -> int:
        """n_2 = len(theta_d) (Eq. 12)."""
        return self.layout.n_d

    @property
    def n_b(self) -> int:
        """n_3 = len(theta_b) = m3 + n_d (Eq. 14)."""
        return self.layout.n_b

    def true_theta_z(self, com_velocity) -> np.ndarray:
        """theta_z = col(v_0, V) for a CoM velocity v_0 [m/s] in the inertial frame (Eq. 4)."""
        v0 = np.asarray(com_velocity, dtype=float).reshape(self.m2)
        return read_only(np.concatenate((v0, self._V_body)))

    def true_theta_b(self, angular_momentum) -> np.ndarray:
        """theta_b = col(A_0, theta_d) for the angular momentum A_0 about the CoM [kg m^2/s]
        (planar a number, spatial a 3-vector), Eq. (14)."""
        A0 = np.asarray(angular_momentum, dtype=float).reshape(self.m3)
        return read_only(np.concatenate((A0, self.theta_d)))

    def pseudo_inertia_table(self) -> PseudoInertiaTable:
        """The linear map theta_d -> P(theta_d), the barycentric pseudo-inertia of this
        model's layout (:mod:`._pseudo_inertia`, docs/robust.md section 1).

        Returns
        -------
        PseudoInertiaTable
            The map as a table (P's size: 2(n+1) planar, n+1 collinear, 3(n+1) spatial).
        """
        return self.layout.pseudo_inertia_table()

    def pseudo_inertia(self, theta_d) -> np.ndarray:
        """P(theta_d), positive semidefinite for the true parameters; ``P >= eps I`` gives
        ``M(q, theta_d) >= eps sigma_min(S)^2 I`` (planar) or positive definite M (spatial) at
        every configuration (docs/robust.md section 1).

        Parameters
        ----------
        theta_d : array_like
            Dynamic parameters (Eq. 12).

        Returns
        -------
        ndarray
            The symmetric pseudo-inertia.
        """
        theta_d = self._check(theta_d, self.n_d, "theta_d")
        return pseudo_inertia(self.pseudo_inertia_table(), theta_d)

    def _check(self, theta, size: int, name: str) -> np.ndarray:
        """``theta`` as a float (or complex) array of shape (size,); a ParameterError naming
        ``name`` otherwise."""
        theta = np.asarray(theta)
        if theta.dtype.kind not in "fc":
            theta = theta.astype(float)
        if theta.shape != (size,):
            raise ParameterError(f"{name} must have shape ({size},), got {theta.shape}")
        return theta


def end_effector_at(model: Any, data: Any, q: np.ndarray, frame_id: int) -> tuple:
    """Joint Jacobians and frame placements of ``data`` computed at ``q``; the end-effector
    frame's Jacobian (``LOCAL_WORLD_ALIGNED``, 6 x nv) and its placement (``pin.SE3``): what
    both roots' state fillers read first.

    Parameters
    ----------
    model, data : pin.Model, pin.Data
        The robot's model and the state's data.
    q : ndarray
        The configuration.
    frame_id : int
        The end-effector frame.

    Returns
    -------
    J_ee, oMe : ndarray, pin.SE3
        The frame's Jacobian and placement.
    """
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J_ee = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)
    return J_ee, data.oMf[frame_id]
