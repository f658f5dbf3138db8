"""What the planar and the spatial barycentric models share: sizes of the parameter vectors,
the true theta_z and theta_b of a state, and the check of a parameter vector's shape."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._arrays import read_only
from ..errors import ParameterError


class BarycentricCommon:
    """Base of :class:`~ffsm_pin.model.planar.BarycentricModel` and
    :class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`."""

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

    def _check(self, theta, size: int, name: str) -> np.ndarray:
        """``theta`` as a float (or complex) array of shape (size,); a ParameterError naming
        ``name`` otherwise."""
        theta = np.asarray(theta)
        if theta.dtype.kind not in "fc":
            theta = theta.astype(float)
        if theta.shape != (size,):
            raise ParameterError(f"{name} must have shape ({size},), got {theta.shape}")
        return theta
