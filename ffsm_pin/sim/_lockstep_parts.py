"""The parts of a lock-step run's step that act on the whole batch (:mod:`.lockstep`): the exact
measurement per root joint (:data:`SENSING`), the sensors' noise (:class:`Noise`), the
controllers' periods (:class:`Control`) and the actuators (:class:`Actuation`); each the
arithmetic of its single run's counterpart (:class:`~.measurement.Sensor`,
:class:`~.sensors.Sensors`, the controller's ``step``, :class:`~.actuators.Actuators`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..control.interface import Measurement
from ..errors import SimulationError
from . import _lockstep_kernels
from ._sensor_kernels import spatial_measurement
from .loop import ControllerFault, checked_torque
from .sensors import BLOCK
from .setup import Setup


def sensing_mode(setup: Setup) -> str | None:
    """What the controller sees: ``"exact"`` (no sensors), ``"ideal"`` (sensors that change
    nothing, recorded as seen), ``"noisy"`` (noise without delay); None: anything else."""
    s = setup.sensors
    if s is None:
        return "exact"
    if s.ideal:
        return "ideal"
    return "noisy" if s.noisy and s.spec.delay == 0 else None


class PlanarSensing:
    """The exact measurement of a planar batch, the arithmetic of
    :class:`~ffsm_pin.sim.measurement.Sensor`: Pinocchio's kinematics and the end-effector
    angle case by case, the continued base angle, q_m and w for the batch at once."""

    rates = np.array([0, 1, 5])  # (dx/dt, dy/dt, attitude rate) of the frame's 6-vector

    def __init__(self, setups: Sequence[Setup]):
        B = len(setups)
        self.models = [s.robot.model for s in setups]
        self.datas = [m.createData() for m in self.models]
        self.angles = [s.model.ee_angle for s in setups]  # type: ignore[attr-defined]
        self.fid = setups[0].robot.ee_frame_id
        self.z_e, self.z_e_dot = np.empty((B, 3)), np.empty((B, 3))
        self.prev: np.ndarray | None = None

    def measure(self, Q, V, live):
        # (math.atan2, the sensor's: numpy's arctan2 gives other bits for some angles)
        q_b = np.array([math.atan2(s, c) for c, s in Q[:, 2:4]])
        if self.prev is not None:  # continuous attitude
            q_b += 2 * math.pi * np.round((self.prev - q_b) / (2 * math.pi))
        self.prev = q_b
        q_m, fid = Q[:, 4:], self.fid
        for b in live:
            model, data = self.models[b], self.datas[b]
            pin.forwardKinematics(model, data, Q[b], V[b])
            self.z_e[b] = pin.updateFramePlacement(model, data, fid).translation
            twist = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED).vector
            self.z_e_dot[b] = twist[self.rates]
            self.z_e[b, 2] = self.angles[b](q_b[b], q_m[b])
        return q_b, q_m, V[:, 2:], self.z_e, self.z_e_dot

    def base_acceleration(self, acc, live):
        return acc[:, 2]


class SpatialSensing:
    """The exact measurement of a free-flyer batch: Pinocchio's kinematics and the sensor's
    compiled MRP arithmetic case by case; the base acceleration by the measured R_0."""

    def __init__(self, setups: Sequence[Setup]):
        B, n = len(setups), setups[0].model.n_joints
        self.models = [s.robot.model for s in setups]
        self.datas = [m.createData() for m in self.models]
        self.fid = setups[0].robot.ee_frame_id
        self.q_b, self.w, self.R0 = np.empty((B, 3)), np.empty((B, n + 3)), np.empty((B, 3, 3))
        self.z_e, self.z_e_dot, self.dw_b = np.empty((B, 6)), np.empty((B, 6)), np.empty((B, 3))

    def measure(self, Q, V, live):
        fid = self.fid
        for b in live:
            model, data = self.models[b], self.datas[b]
            pin.forwardKinematics(model, data, Q[b], V[b])
            oMf = pin.updateFramePlacement(model, data, fid)
            twist = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            q_b, R0, z_e, z_e_dot, w = spatial_measurement(Q[b], V[b], oMf.homogeneous,
                                                           twist.vector)  # fmt: skip
            self.q_b[b], self.R0[b], self.z_e[b], self.z_e_dot[b], self.w[b] = (
                q_b,
                R0,
                z_e,
                z_e_dot,
                w,
            )
        return self.q_b, Q[:, 7:], self.w, self.z_e, self.z_e_dot

    def base_acceleration(self, acc, live):
        for b in live:  # (ndarray.dot, as the sensor's: the same BLAS call)
            self.dw_b[b] = self.R0[b].dot(acc[b, 3:6])
        return self.dw_b


#: The batch's exact measurement per root joint (``robot.base``): what differs between the
#: geometries, as the sensor's and the plant's tables.
SENSING: dict[str, type[PlanarSensing] | type[SpatialSensing]] = {
    "planar": PlanarSensing,
    "free-flyer": SpatialSensing,
}


class Noise:
    """The sensors' noise of a batch: each case's own stream, drawn :data:`~.sensors.BLOCK`
    measurements at a time as :meth:`~.sensors.Sensors.observe` draws it, split by key once a
    block; nothing without noisy sensors."""

    def __init__(self, setups: Sequence[Setup]):
        self.sensors = [s.sensors for s in setups]
        self.noisy = sensing_mode(setups[0]) == "noisy"
        self.row = BLOCK  # next row of the current block (none drawn yet)
        self.parts: list[np.ndarray] = []  # per field: (BLOCK, B, ...) of the block

    def add(self, exact: tuple) -> tuple:
        """What the controllers see of the ``exact`` measurement (q_b, q_m, w, z_e, z_e_dot)."""
        if not self.noisy:
            return exact
        if self.row == BLOCK:
            z = np.stack([s.noise_block() for s in self.sensors], axis=1)  # type: ignore[union-attr]
            sl = self.sensors[0].noise_slices  # type: ignore[union-attr]
            base = z[:, :, sl["base_attitude"]]
            parts = (
                base[:, :, 0] if exact[0].ndim == 1 else base, z[:, :, sl["joints"]],
                np.concatenate((z[:, :, sl["base_rate"]], z[:, :, sl["joint_rates"]]), axis=2),
                z[:, :, sl["ee_pose"]], z[:, :, sl["ee_velocity"]],
            )  # fmt: skip
            self.parts = [np.ascontiguousarray(p) for p in parts]
            self.row = 0
        i = self.row
        self.row += 1
        return tuple(x + part[i] for x, part in zip(exact, self.parts, strict=True))


class Control:
    """The batch's controllers: their compiled periods in one call of their batch kernel
    (:mod:`ffsm_pin.control.lockstep`), the bookkeeping of the periods that are not plain case
    by case (the controller's ``settle``), the run's own check of every torque."""

    def __init__(self, setups: Sequence[Setup], handles: Sequence):
        B, n = len(setups), setups[0].model.n_joints
        self.controllers: list = [s.controller for s in setups]  # (settle, damped_since)
        self.items = _lockstep_kernels.listed(handles[0].item, B)
        for b, h in enumerate(handles):
            _lockstep_kernels.put(self.items, b, h.item)
        self.kernel, self.M, self.h = handles[0].kernel, handles[0].M, handles[0].h
        self.u = np.zeros((B, n))  # the commanded torques [N m]
        self.booked = np.zeros(B, dtype=np.bool_)  # damped before: settled every period
        self.out = (np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64), np.zeros(B),
                    self.u, np.zeros(B), self.booked, np.zeros(B, dtype=np.bool_))  # fmt: skip
        self.faulty = np.zeros(B, dtype=np.bool_)

    def step(self, t, dt, seen, active, signals, j):
        """Each active case's period at ``t``; yields ``(case, stop)`` of those that stop."""
        if self.kernel(self.items, dt, t, seen, self.M, self.h, active, self.out, signals, j):
            status, idx, value, _, _, booked, book = self.out
            q_b, q_m, w, z_e, z_e_dot = seen
            for b in np.flatnonzero(book):
                q_b_seen = float(q_b[b]) if q_b.ndim == 1 else q_b[b]
                meas = Measurement(t, q_b_seen, q_m[b], w[b], z_e[b], z_e_dot[b], None, None)
                controller = self.controllers[b]
                try:
                    controller.settle(meas, int(status[b]), int(idx[b]), float(value[b]))
                except SimulationError as exc:
                    yield b, exc
                    active[b] = False  # (the caller stops it; not checked below)
                booked[b] = controller.damped_since is not None
        if _lockstep_kernels.torque_faults(self.u, active, self.faulty):  # the run's check
            for b in np.flatnonzero(self.faulty):
                try:
                    checked_torque(self.u[b].copy(), self.u.shape[1])
                except ControllerFault as fault:
                    yield b, SimulationError(f"t = {t:.4f} s: {fault}", time=t, cause="controller")


class Actuation:
    """The batch's actuators: each case's by the actuators' own compiled step, in one call,
    with their saturation counts; the commands themselves with ideal actuators."""

    def __init__(self, setups: Sequence[Setup]):
        B, n = len(setups), setups[0].model.n_joints
        self.acts = [s.actuators for s in setups]
        a0 = self.acts[0]
        self.ideal = a0 is None or a0.ideal
        self.periods_at = np.zeros(B, dtype=np.int64)  # periods with a joint at its limit
        self.per_joint = np.zeros((B, n), dtype=np.int64)
        if self.ideal:
            return
        acts = self.acts
        self.x = np.array([a.x for a in acts])  # type: ignore[union-attr]
        self.limits = (
            np.array([a.limit for a in acts]), np.array([float(a.alpha) for a in acts]),  # type: ignore[union-attr]
            np.array([a.lagged for a in acts]), np.array([a.max_change for a in acts]),  # type: ignore[union-attr]
            np.array([a.rate_limited for a in acts]),  # type: ignore[union-attr]
        )  # fmt: skip
        self.zeros, self.u_m = np.zeros(n), np.empty((B, n))

    def apply(self, u_cmd, active):
        """The applied torques [N m] of the active cases for the commands ``u_cmd``."""
        if self.ideal:
            return u_cmd
        _lockstep_kernels.actuate_all(u_cmd, self.x, self.limits, self.zeros, self.u_m, active,
                                      (self.periods_at, self.per_joint))  # fmt: skip
        return self.u_m

    def finish(self) -> None:
        """Hand each case's torque state and saturation counts back to its actuators."""
        if self.ideal:
            return
        for a, x, counts in zip(self.acts, self.x, self.per_joint, strict=True):
            a.x[:] = x  # type: ignore[union-attr]
            a.saturated_periods += counts  # type: ignore[union-attr]
