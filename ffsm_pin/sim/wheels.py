"""Reaction wheels on the bus (issue 40, ``[robot.satellite.wheels]``): a pure-momentum device
outside Pinocchio's model (docs/capture.md, "Reaction wheels").

The state of N wheels is h (N,) [N m s]: each wheel's absolute angular momentum about its axis
(column i of A, 3 x N, unit vectors in the bus frame). A motor torque tau_i on wheel i changes
h_i at the rate tau_i; the bus feels the opposite, plus the gyroscopic torque of the wheels'
momentum turning with the bus:

    dh/dt = tau_w,        torque on the bus (bus frame) = -(A tau_w + w_b x A h)

with w_b the bus's angular velocity (bus frame). The total angular momentum (world, about the
system CoM) is then

    L_total = L_robot + R_b A h,

L_robot Pinocchio's centroidal momentum of the robot's model, R_b the bus attitude; the
linear momentum is the robot's alone (a wheel is a couple). These are the equations of a
gyrostat (a rigid body carrying axisymmetric rotors; Hughes, "Spacecraft Attitude Dynamics",
1986). They are exact, not an approximation, when the robot's model holds each rotor's mass
and its inertia except the axial moment J_s, which h carries: h_i = J_s,i (a_i . w_b +
Omega_i), Omega_i the spin relative to the bus (:meth:`Wheels.spin_rates`). An axisymmetric
rotor's axial momentum changes only by the motor torque, whatever the bus does.

:class:`WheeledPlant` steps a :class:`~.plant.Plant` with the bus torque as a base wrench held
over each step and restores L_total (not the robot's own momentum) by the plant's projection,
so L_total is kept to rounding; the held bus torque makes the trajectory first order in dt
(tests/sim/test_wheels.py compares it with the wheels as Pinocchio bodies).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .._docstrings import doc_entries, fill_doc
from ..errors import ParameterError
from ..robot.wheels import Wheels
from ._docs import SIM_DOC
from .plant import Plant

__all__ = ["WheelStep", "WheeledPlant", "Wheels"]

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = SIM_DOC | doc_entries(
    h_ndarray="""
        h : ndarray, shape (k,)
            Wheel momenta [N m s].""",
)


class WheelStep(NamedTuple):
    """State after one :meth:`WheeledPlant.advance`."""

    q: np.ndarray  # robot configuration
    v: np.ndarray  # robot velocity
    h: np.ndarray  # wheel momenta [N m s]
    a: np.ndarray  # ABA acceleration at the start (with the wheels' torque on the bus)
    tau_w: np.ndarray  # wheel torques applied in the last plant step (after the limits) [N m]


@fill_doc(_DOC)
class WheeledPlant:
    """A :class:`~.plant.Plant` whose bus carries :class:`Wheels`; L_total is kept.

    Parameters
    ----------
    robot : Robot or pin.Model
        As for :class:`~.plant.Plant` (planar or free-flyer root; on a planar root only the
        z component of the wheels' momentum and torque acts).
    wheels : Wheels
        The wheels, axes in the root joint's frame.
    integrator : str
        The plant's integrator.
    project_momentum : bool
        Restore L_total after each step (default); off only to measure the bare drift.
    project_position : bool
        Keep the CoM on its straight line (the plant's position projection; the wheels'
        torque is a couple, so the line is the same as without them).
    """

    def __init__(
        self,
        robot,
        wheels: Wheels,
        *,
        integrator: str = "semi-implicit",
        project_momentum: bool = True,
        project_position: bool = False,
    ):
        self.plant = Plant(
            robot,
            integrator=integrator,
            project_momentum=False,
            project_position=project_position,
        )
        self.wheels = wheels
        self.project_momentum = project_momentum
        self._planar = self.plant.root == "JointModelPlanar"
        self._root_rotation = np.array(self.plant.model.jointPlacements[1].rotation)
        self.total0: np.ndarray | None = None

    def bus_rotation(self, q) -> np.ndarray:
        """R_b: the bus (root joint) frame's attitude in the world."""
        q = np.asarray(q, dtype=float)
        if self._planar:
            c, s = q[2], q[3]
            rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        else:
            rot = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().matrix()
        return self._root_rotation @ rot

    def bus_rate(self, v) -> np.ndarray:
        """w_b: the bus's angular velocity in its own frame [rad/s]."""
        v = np.asarray(v, dtype=float)
        return np.array([0.0, 0.0, v[2]]) if self._planar else v[3:6].copy()

    def stored(self, q, h) -> np.ndarray:
        """The wheels' share of the plant's conserved rows: free-flyer (0, 0, 0, R_b A h),
        planar (0, 0, (R_b A h)_z).

        Parameters
        ----------
        q : ndarray
            Robot configuration (Pinocchio convention).
        %(h_ndarray)s

        Returns
        -------
        ndarray
            The conserved rows the wheels hold, (3,) planar or (6,) free-flyer.
        """
        L = self.bus_rotation(q) @ self.wheels.momentum_bus(h)
        return np.array([0.0, 0.0, L[2]]) if self._planar else np.concatenate((np.zeros(3), L))

    def total_momentum(self, q, v, h) -> np.ndarray:
        """The plant's conserved rows of robot plus wheels (P, L_total).

        Parameters
        ----------
        q, v : ndarray
            Robot state (Pinocchio convention).
        %(h_ndarray)s

        Returns
        -------
        ndarray
            (P, L_total), the plant's conserved rows.
        """
        return self.plant.momentum(q, v) + self.stored(q, h)

    def reset(self, q, v, h) -> None:
        """Set the total momentum to keep from the initial state.

        Parameters
        ----------
        q, v : ndarray
            The initial robot state (Pinocchio convention).
        h : ndarray, shape (k,)
            The initial wheel momenta [N m s].
        """
        self.plant.reset(q, v)
        self.total0 = self.total_momentum(q, v, h)

    def _wrench(self, torque: np.ndarray) -> np.ndarray:
        if self._planar:
            return np.array([0.0, 0.0, torque[2]])
        return np.concatenate((np.zeros(3), torque))

    def advance(self, q, v, h, u_m, tau_w, dt: float, substeps: int = 1) -> WheelStep:
        """Advance by one control step ``dt`` [s] in ``substeps`` plant steps, joint torques
        ``u_m`` [N m] and commanded wheel torques ``tau_w`` [N m] held (each plant step
        limits them, :meth:`Wheels.limit`, and holds the bus torque over the step).

        Parameters
        ----------
        q, v : ndarray
            Robot state at the start (Pinocchio convention).
        %(h_ndarray)s
        %(u_m_held)s
        tau_w : ndarray, shape (k,)
            Commanded wheel torques [N m], held.
        %(dt_substeps)s

        Returns
        -------
        WheelStep
            (q, v, h) after dt and the acceleration at the start.
        """
        if substeps < 1:
            raise ParameterError(f"wheels: substeps must be >= 1, got {substeps}")
        if self.total0 is None:
            self.reset(q, v, h)
        h = np.asarray(h, dtype=float)
        dt_s = dt / substeps
        a = None
        for _ in range(substeps):
            tau = self.wheels.limit(h, tau_w, dt_s)
            torque = self.wheels.bus_torque(h, tau, self.bus_rate(v))
            res = self.plant.step(q, v, u_m, dt_s, base_wrench=self._wrench(torque))
            a = res.a if a is None else a
            h = h + dt_s * tau
            q, v = res.q, res.v
            if self.project_momentum:
                v = self.plant.project(q, v, self.total0 - self.stored(q, h))
        return WheelStep(q, v, h, a, tau)  # type: ignore[arg-type]  # substeps >= 1
