"""The exact measurement of the plant state: what a controller needs, from Pinocchio's
kinematics (sensor noise and delay act on it afterwards, :mod:`.sensors`)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..control.interface import Measurement
from ..model import ReducedModel, State
from ._sensor_kernels import spatial_measurement


class Sensor:
    """Measures what the controller needs from the plant state (Pinocchio kinematics).

    Planar: q_b the continuous base angle, z_e = (x, y, attitude). Free-flyer
    (docs/spatial.md section 1): q_b the base MRP, w = (R_0 w_B, dq_m) with w_b in the
    inertial frame, z_e = (p_e, q_e) with q_e the end-effector MRP (both on the |s| <= 1
    branch), dz_e/dt = (dp_e/dt, 1/4 B(q_e) R_e^T w_e).

    Parameters
    ----------
    robot : Robot
        The plant's robot.
    model : ReducedModel
        Its reduced model.
    full_model : bool
        Also measure the true M and C w (``Measurement.M``, ``.h``).
    """

    def __init__(self, robot, model: ReducedModel, full_model: bool):
        self.robot = robot
        self.pmodel = robot.model
        self.data = self.pmodel.createData()
        self.model = model
        self.fid = robot.ee_frame_id
        self.full_model = full_model
        self._measure, self._base_acceleration = _SENSING[robot.base]
        self.state = State(robot) if full_model else None
        self._q_b_prev: float | None = None
        self.R0: np.ndarray | None = None  # spatial: base rotation of the last measurement

    def reset(self) -> None:
        """Forget the last measurement: the next planar base angle is taken on (-pi, pi], not
        continued from the previous one (a run measures t = 0 again after a warm-up)."""
        self._q_b_prev = None

    def base_angular_acceleration(self, a: np.ndarray):
        """The paper's dw_b/dt from the plant's acceleration ``a`` (Pinocchio convention) at
        the last measured state: planar a number [rad/s^2]; free-flyer the 3-vector in the
        inertial frame, R_0(q_b) of the last measurement times the body-frame one
        (docs/spatial.md 1)."""
        return self._base_acceleration(self, a)

    def _base_acceleration_planar(self, a: np.ndarray) -> float:
        return a[2]

    def _base_acceleration_spatial(self, a: np.ndarray) -> np.ndarray:
        assert self.R0 is not None  # set by the measurement
        # (ndarray.dot: the same BLAS dgemv as ``@``, without the matmul ufunc's dispatch:
        # 0.4 of its 0.9 us, benchmarks/README.md "A step's parts")
        return self.R0.dot(a[3:6])

    def measure(self, t: float, q: np.ndarray, v: np.ndarray) -> Measurement:
        """The exact measurement at time ``t`` [s] of the plant state (q, v).

        Parameters
        ----------
        t : float
            Time [s].
        q, v : ndarray
            The plant state (Pinocchio convention).

        Returns
        -------
        Measurement
            The measurement.
        """
        return self._measure(self, t, q, v)

    def _measure_planar(self, t: float, q: np.ndarray, v: np.ndarray) -> Measurement:
        q_b = math.atan2(q[3], q[2])
        if self._q_b_prev is not None:  # continuous attitude
            q_b += 2 * math.pi * round((self._q_b_prev - q_b) / (2 * math.pi))
        self._q_b_prev = q_b
        pmodel, data, fid = self.pmodel, self.data, self.fid
        pin.forwardKinematics(pmodel, data, q, v)
        z_e = pin.updateFramePlacement(pmodel, data, fid).translation.copy()  # (x, y, .)
        vel = pin.getFrameVelocity(pmodel, data, fid, _WORLD_ALIGNED)
        q_m = q[4:].copy()
        z_e[2] = self.model.ee_angle(q_b, q_m)  # type: ignore[attr-defined]  # planar model's
        z_e_dot = vel.vector[_PLANAR_RATES]  # (dx/dt, dy/dt, attitude rate) of the 6-vector
        M = h = None
        if self.state is not None:  # full_model
            self.state.update_dynamics(q, v)  # M, h only
            M, h = self.state.M, self.state.h
        return Measurement(t, q_b, q_m, v[2:].copy(), z_e, z_e_dot, M, h)

    def _measure_spatial(self, t: float, q: np.ndarray, v: np.ndarray) -> Measurement:
        pmodel, data, fid = self.pmodel, self.data, self.fid
        pin.forwardKinematics(pmodel, data, q, v)
        oMf = pin.updateFramePlacement(pmodel, data, fid)
        vel = pin.getFrameVelocity(pmodel, data, fid, _WORLD_ALIGNED)
        q_b, R0, z_e, z_e_dot, w = spatial_measurement(  # the MRP arithmetic, compiled
            q, v, oMf.homogeneous, vel.vector
        )
        self.R0 = R0  # kept for the recorder (one evaluation a step)
        M = h = None
        if self.state is not None:  # full_model
            self.state.update_dynamics(q, v)  # M, h only
            M, h = self.state.M, self.state.h
        return Measurement(t, q_b, q[7:].copy(), w, z_e, z_e_dot, M, h)


#: The frame of the measured end-effector twist (looked up once, not per measurement).
_WORLD_ALIGNED = pin.LOCAL_WORLD_ALIGNED

#: The planar measured rates' entries in the frame's world-aligned (linear, angular) 6-vector.
_PLANAR_RATES = np.array([0, 1, 5])


# root joint (``robot.base``) -> (its measurement, its base angular acceleration): what the
# sensor does differently per geometry (the plant's table: ``sim/plant.py``)
_SENSING = {
    "planar": (Sensor._measure_planar, Sensor._base_acceleration_planar),
    "free-flyer": (Sensor._measure_spatial, Sensor._base_acceleration_spatial),
}
