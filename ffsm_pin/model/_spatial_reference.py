"""The vectorised numpy reference of the spatial model (``backend="numpy"``, and complex
arguments on either backend): the matrices S_k of a configuration, the tangents of R_k and
z_j along the motion and along each joint, and the bilinear cores M a, T and M for real or
complex R and S (the complex step of :mod:`ffsm_pin.model.spatial` passes through them).

:class:`SpatialReference` is the base of
:class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`, which sets the attributes it reads.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._common import BarycentricCommon
from ._spatial_layout import SYM6


class Kinematics(NamedTuple):
    """Rotations of one configuration (see
    :meth:`~ffsm_pin.model.spatial.SpatialBarycentricModel.kinematics`)."""

    R: np.ndarray  # (n+1, 3, 3) body rotations R_k (body to inertial)
    z: np.ndarray  # (n, 3) inertial joint axes z_j
    S: np.ndarray  # (n+1, 3, n+3) S_k: w_k = S_k w


def _phi6(beta):
    """(..., 3) -> (..., 3, 6): Jbar beta = Phi(beta) (xx, xy, xz, yy, yz, zz)."""
    out = np.zeros((*beta.shape, 6), dtype=beta.dtype)
    b1, b2, b3 = beta[..., 0], beta[..., 1], beta[..., 2]
    out[..., 0, 0] = b1
    out[..., 0, 1] = b2
    out[..., 1, 1] = b1
    out[..., 0, 2] = b3
    out[..., 2, 2] = b1
    out[..., 1, 3] = b2
    out[..., 1, 4] = b3
    out[..., 2, 4] = b2
    out[..., 2, 5] = b3
    return out


def skew_batch(v):
    """(..., 3) -> (..., 3, 3) cross-product matrices."""
    out = np.zeros((*v.shape, 3), dtype=v.dtype)
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


class SpatialReference(BarycentricCommon):
    """The numpy reference's configuration terms and bilinear cores (methods of
    :class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`, which sets these attributes)."""

    n_joints: int  # n
    _nb: int  # n + 1 bodies
    _N: int  # n + 3 velocity components
    _P: int  # body pairs k < l
    _K: np.ndarray  # (P,) first body of each pair
    _L: np.ndarray  # (P,) second body of each pair
    _smask: np.ndarray  # (n+1, n) S[k, :, 3 + j] = z_j where 1
    _below: np.ndarray  # (n, n+1) dR_k/dq_j nonzero where 1
    _after: np.ndarray  # (n, n) dz_i/dq_j nonzero where 1

    def _s_matrix(self, z, mask=None):
        """S (..., n+1, 3, n+3) from joint axes z (..., n, 3)."""
        mask = self._smask if mask is None else mask
        lead = z.shape[:-2]
        S = np.zeros((*lead, self._nb, 3, self._N), dtype=z.dtype)
        S[..., :, :, :3] = np.eye(3)
        S[..., :, :, 3:] = np.swapaxes(z, -1, -2)[..., None, :, :] * mask[:, None, :]
        return S

    def _motion_tangent(self, kin: Kinematics, w):
        """(dR/dt, dS/dt) along w: dR_k = [w_k]x R_k, dz_j = w_j x z_j."""
        om = kin.S @ w  # (nb, 3) body angular velocities
        dR = skew_batch(om) @ kin.R
        dz = np.cross(om[1:], kin.z)
        dS = np.zeros_like(kin.S)
        dS[:, :, 3:] = dz.T[None] * self._smask[:, None, :]
        return dR, dS

    def _joint_tangents(self, kin: Kinematics):
        """(dR/dq_j, dS/dq_j) for every joint j, stacked on a leading axis of length n."""
        Z = skew_batch(kin.z)  # (n, 3, 3)
        dR = np.einsum("jxy,kyz->jkxz", Z, kin.R) * self._below[:, :, None, None]
        dz = np.cross(kin.z[:, None, :], kin.z[None, :, :]) * self._after[:, :, None]
        dS = np.zeros((self.n_joints, *kin.S.shape), dtype=kin.S.dtype)
        dS[..., 3:] = np.swapaxes(dz, -1, -2)[:, None, :, :] * self._smask[None, :, None, :]
        return dR, dS

    # ------------------------------------------------------------------ bilinear cores
    def _ym_core(self, R, S, a):
        """Y with Y theta_d = M a, for rotations R and S (real or complex)."""
        K, L = self._K, self._L
        b = S @ a  # (nb, 3)
        beta = np.einsum("kyx,ky->kx", R, b)
        Yd = R @ _phi6(beta)  # (nb, 3, 6)
        RK, RL = R[K], R[L]
        Q = np.einsum("pyi,pyj->pij", RK, RL)
        bK, bL = b[K], b[L]
        u = np.einsum("pyi,py->pi", RK, bL)
        gam = np.einsum("pyj,py->pj", RL, bK)
        A = Q[:, None] * bL[:, :, None, None] - u[:, None, :, None] * RL[:, :, None, :]
        Bm = Q[:, None] * bK[:, :, None, None] - gam[:, None, None, :] * RK[:, :, :, None]
        Y = np.empty((self._N, self.n_d), dtype=A.dtype)
        Y[:, : 6 * self._nb] = np.einsum("kxn,kxc->nkc", S, Yd).reshape(self._N, -1)
        Y[:, 6 * self._nb :] = (
            np.einsum("pxn,pxc->npc", S[K], A.reshape(self._P, 3, 9))
            + np.einsum("pxn,pxc->npc", S[L], Bm.reshape(self._P, 3, 9))
        ).reshape(self._N, -1)
        return Y

    def _energy_core(self, R, S, w):
        """Row y with y theta_d = T (kinetic energy about the CoM), batched over leading axes."""
        K, L = self._K, self._L
        om = np.einsum("...kxn,n->...kx", S, w)
        beta = np.einsum("...kyx,...ky->...kx", R, om)
        b1, b2, b3 = beta[..., 0], beta[..., 1], beta[..., 2]
        diag = np.stack((b1 * b1 / 2, b1 * b2, b1 * b3, b2 * b2 / 2, b2 * b3, b3 * b3 / 2), -1)
        RK, RL = R[..., K, :, :], R[..., L, :, :]
        omK, omL = om[..., K, :], om[..., L, :]
        Q = np.einsum("...pyi,...pyj->...pij", RK, RL)
        dot = np.einsum("...px,...px->...p", omK, omL)
        u = np.einsum("...pyi,...py->...pi", RK, omL)
        gam = np.einsum("...pyj,...py->...pj", RL, omK)
        pair = Q * dot[..., None, None] - u[..., :, None] * gam[..., None, :]
        lead = diag.shape[:-2]
        return np.concatenate((diag.reshape(*lead, -1), pair.reshape(*lead, -1)), axis=-1)

    def _mass_core(self, R, S, theta_d):
        nb, P = self._nb, self._P
        j6 = theta_d[: 6 * nb].reshape(nb, 6)
        J = np.empty((nb, 3, 3), dtype=j6.dtype)
        for c, (i, j) in enumerate(SYM6):
            J[:, i, j] = j6[:, c]
            J[:, j, i] = j6[:, c]
        D = theta_d[6 * nb :].reshape(P, 3, 3)
        RJR = R @ J @ np.swapaxes(R, 1, 2)
        M = np.einsum("kxn,kxy,kym->nm", S, RJR, S)
        if P:
            RK, RL = R[self._K], R[self._L]
            X = RK @ D @ np.swapaxes(RL, 1, 2)
            tr = np.trace(X, axis1=1, axis2=2)
            Kmat = tr[:, None, None] * np.eye(3) - np.swapaxes(X, 1, 2)
            C = np.einsum("pxn,pxy,pym->nm", S[self._K], Kmat, S[self._L])
            M = M + C + C.T
        return M
