"""The plant: semi-implicit Euler on Pinocchio's ABA, with momentum projection.

One step (docs/model.md section 4):

1. ``a = ABA(q, v, tau)`` with ``tau = (0, 0, 0, u_m)`` (free-floating: no base actuation,
   zero gravity);
2. ``v+ = v + dt a``, ``q+ = integrate(q, dt v+)`` (semi-implicit / symplectic Euler on the
   configuration Lie group, never ``q + v dt``);
3. projection: the base twist is recomputed from the conserved centroidal momentum at the
   new configuration, ``A_g,base(q+) v_base = h_0 - A_g,joints(q+) w_m``, so the linear
   momentum P and the angular momentum L about the CoM are conserved to rounding for any dt.

Plain semi-implicit Euler drifts in momentum by O(dt); the projection removes that drift
without changing the order of accuracy of the trajectory.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin
from numba import njit

from ..robot import FreeFloatingRobot

_MOMENTUM_ROWS = (0, 1, 5)  # planar: P_x, P_y, L_z of the centroidal momentum


@njit(cache=True)
def _project_base(Ag: np.ndarray, v: np.ndarray, h0: np.ndarray) -> np.ndarray:
    """v with its base twist replaced by the solution of
    ``A_g,base v_base = h0 - A_g,joints v_joints`` on the rows (P_x, P_y, L_z) of A_g.

    Compiled: it is three lines of linear algebra on a 3 x 3 system, which numpy's wrappers
    make cost more than the rest of the plant step.
    """
    A = np.empty((3, 3))
    rhs = h0.copy()
    for r, row in enumerate(_MOMENTUM_ROWS):
        for j in range(3):
            A[r, j] = Ag[row, j]
        for j in range(3, v.size):
            rhs[r] -= Ag[row, j] * v[j]
    out = v.copy()
    out[:3] = np.linalg.solve(A, rhs)
    return out


class StepResult(NamedTuple):
    """State after one step and the acceleration used for it."""

    q: np.ndarray  # configuration after the step (Pinocchio convention)
    v: np.ndarray  # velocity after the step (Pinocchio convention, base twist in base frame)
    a: np.ndarray  # ABA acceleration at the start of the step [nv]


class Plant:
    """Momentum-exact integrator of a planar free-floating robot.

    Parameters
    ----------
    robot:
        The loaded robot.
    project_momentum:
        Apply the momentum projection after each step (default). Switch it off only to
        measure the drift of plain semi-implicit Euler.
    """

    def __init__(self, robot: FreeFloatingRobot, *, project_momentum: bool = True):
        self.robot = robot
        self.model = robot.model
        self.data = self.model.createData()
        self.project_momentum = project_momentum
        self._tau = np.zeros(self.model.nv)
        self.momentum0: np.ndarray | None = None  # (P_x, P_y, L_z) to conserve

    def momentum(self, q, v) -> np.ndarray:
        """(P_x, P_y, L_z): linear momentum (inertial frame) [kg m/s] and angular momentum
        about the system CoM [kg m^2/s]."""
        pin.computeCentroidalMomentum(self.model, self.data, q, v)
        hg = self.data.hg
        return np.array([hg.linear[0], hg.linear[1], hg.angular[2]])

    def reset(self, q, v) -> None:
        """Set the momentum to be conserved from the initial state."""
        self.momentum0 = self.momentum(q, v)

    def acceleration(self, q, v, u_m) -> np.ndarray:
        """Forward dynamics (ABA) with joint torques ``u_m`` [N m] and a free base."""
        self._tau[3:] = u_m
        return pin.aba(self.model, self.data, q, v, self._tau).copy()

    def step(self, q, v, u_m, dt: float) -> StepResult:
        """Advance (q, v) by ``dt`` [s] with joint torques ``u_m`` held constant."""
        if self.momentum0 is None:
            self.reset(q, v)
        a = self.acceleration(q, v, u_m)
        v_new = v + dt * a
        q_new = pin.integrate(self.model, q, dt * v_new)
        if self.project_momentum:
            v_new = self.project(q_new, v_new)
        return StepResult(q_new, v_new, a)

    def project(self, q, v) -> np.ndarray:
        """Base twist that restores the conserved momentum at q, joint rates unchanged."""
        return _project_base(pin.computeCentroidalMap(self.model, self.data, q), v, self.momentum0)
