"""The post-capture task of an approach (issue 40): the hand, and so the held target, held
steady relative to the bus.

After the grasp the system drifts: the target brought momentum, so the whole system's CoM moves
at its constant velocity, and a hand held still in the inertial frame lets the bus move
relative to it. :class:`BusHold` gives the end-effector reference that holds the hand fixed in
the bus frame instead, from what the controller measures (the bus attitude R_b, its angular
velocity w_b, the joint angles and rates, the end-effector position and velocity) and the
robot's kinematics: with f(q_m) the end-effector position in the bus frame, J_f its joint
Jacobian and r(t) the bus-frame point the hand is to hold,

    z_d = z_e + R_b (r - f(q_m)),
    dz_d/dt = dz_e/dt + w_b x R_b (r - f) + R_b (dr/dt - J_f w_m),
    d^2z_d/dt^2 = R_b d^2r/dt^2 (the bus's and the arm's accelerations left out),

so that the task error z_e - z_d = R_b (f(q_m) - r) is the hand's bus-frame error (the end
effector's measurement noise cancels from it) and its rate the hand's velocity relative to the
bus less dr/dt. r comes to rest as the approach's inertial hold did: from the hand's bus-frame
position f_c and velocity u_c = J_f w_m just after the impact,
r = f_c + u_c T (1 - exp(-(t - t_c) / T)), T = ``approach.HOLD_TIME``, so the error and its
rate start at zero. docs/capture.md, "The controller after capture".
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..attitude import mrp


class BusHold:
    """The end-effector reference that holds the hand fixed in the bus frame after a capture.

    Parameters
    ----------
    robot : Robot
        The robot (free-flyer root; its kinematics, without the held body: a payload does not
        move a frame).
    time_constant : float
        T [s], the time with which the bus-frame point comes to rest.
    """

    def __init__(self, robot, time_constant: float) -> None:
        self.model = robot.model
        self.data = robot.model.createData()
        self.fid = robot.ee_frame_id
        self.q = pin.neutral(robot.model)  # the bus at the origin, unturned: world = bus frame
        self.T = float(time_constant)
        self._start: tuple[float, np.ndarray, np.ndarray] | None = None  # t_c, f_c, u_c

    def hand_in_bus(self, q_m) -> tuple[np.ndarray, np.ndarray]:
        """f(q_m) [m], the end-effector position in the bus frame, and its joint Jacobian J_f.

        Parameters
        ----------
        q_m : ndarray
            Joint angles [rad].

        Returns
        -------
        f : ndarray, shape (3,)
            The position.
        J_f : ndarray, shape (3, n_joints)
            df/dq_m.
        """
        q = self.q
        q[7:] = q_m
        J = pin.computeFrameJacobian(self.model, self.data, q, self.fid, pin.LOCAL_WORLD_ALIGNED)
        return self.data.oMf[self.fid].translation.copy(), J[:3, 6:]

    def reference(self, meas) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """z_d, dz_d/dt, d^2z_d/dt^2 (3,) of the period starting at ``meas.t`` (the module
        docstring); the first call, the period of the capture, fixes t_c, f_c and u_c.

        Parameters
        ----------
        meas : Measurement
            What the controller is given (spatial: w = (inertial w_b, w_m)).

        Returns
        -------
        z, dz, ddz : ndarray, shape (3,)
            [m], [m/s], [m/s^2].
        """
        t = float(meas.t)
        w_b, w_m = meas.w[:3], meas.w[3:]
        f, J_f = self.hand_in_bus(meas.q_m)
        u = J_f @ w_m  # the hand's velocity relative to the bus, bus frame
        if self._start is None:
            self._start = (t, f, u)
        t0, f0, u0 = self._start
        decay = np.exp(-(t - t0) / self.T)
        r = f0 + u0 * self.T * (1.0 - decay)
        dr, ddr = u0 * decay, -u0 * decay / self.T
        R_b = mrp.to_rotation(meas.q_b)
        off = R_b @ (r - f)
        z = meas.z_e[:3] + off
        dz = meas.z_e_dot[:3] + np.cross(w_b, off) + R_b @ (dr - u)
        return z, dz, R_b @ ddr
