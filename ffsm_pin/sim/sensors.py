"""What the controller sees: the exact measurement with seeded Gaussian noise and a delay.

The run measures the plant exactly (``ffsm_pin.sim.measurement.Sensor``); :class:`Sensors`
turns that into what the controller is given. Noise and delay act on this copy only: the plant, its
momentum and the recorded true signals stay exact. With the defaults (no noise, no delay)
the controller gets the exact measurement itself.

At control period k, with delay d, the controller gets the measurement of period
max(k - d, 0) plus its noise, stamped with the current time t_k (the controller's clock is
exact; its data are old). Noise is drawn once per measurement, in the order joints, joint
rates, base attitude, base rate, end-effector pose, end-effector velocity, from one
``numpy.random.default_rng(seed)`` stream. The model quantities of the known-model scheme
(M, C w) are passed on from the delayed measurement without noise.

See docs/controllers.md, "Sensors".
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..control.controller import Measurement
from ..errors import ParameterError, expected_count
from ..scenario.devices import NOISE_KEYS, SensorSpec

BLOCK = 1024  # measurements whose noise is drawn in one call


class Sensors:
    """The sensor model of :class:`SensorSpec` for ``n`` joints, m3 attitude components and an
    end-effector pose of ``n_pose`` components.

    Parameters
    ----------
    spec : SensorSpec
        The scenario's ``[sensors]``.
    n : int
        Number of joints.
    m3 : int
        Attitude components.
    n_pose : int
        End-effector pose components.
    """

    def __init__(self, spec: SensorSpec, n: int, m3: int, n_pose: int):
        if spec.delay < 0:
            raise ParameterError(f"sensors.delay = {spec.delay}: must be >= 0 control periods")
        self.spec = spec
        self.ideal = spec.ideal
        sizes = {"joints": n, "joint_rates": n, "base_attitude": m3, "base_rate": m3}
        sizes |= {"ee_pose": n_pose, "ee_velocity": n_pose}
        given = dict(spec.noise)
        unknown = sorted(set(given) - set(NOISE_KEYS))
        if unknown:
            raise ParameterError(
                f"sensors.noise.{unknown[0]}: unknown; valid keys: {', '.join(NOISE_KEYS)}"
            )
        self.sigma: dict[str, np.ndarray] = {}
        for key in NOISE_KEYS:
            arr = np.asarray(given.get(key, 0.0), dtype=float)
            size = sizes[key]
            arr = np.full(size, float(arr)) if arr.ndim == 0 else arr
            if arr.shape != (size,):
                raise ParameterError(
                    f"sensors.noise.{key}: {arr.size} values, expected {expected_count(size)}"
                )
            if np.any(arr < 0) or not np.all(np.isfinite(arr)):
                raise ParameterError(f"sensors.noise.{key} = {arr.tolist()}: must be >= 0")
            self.sigma[key] = arr
        self.rng = np.random.default_rng(spec.seed)
        self.buffer: deque[tuple] = deque(maxlen=spec.delay + 1)  # measurements without t
        self._scalar_base = m3 == 1  # planar: q_b is a number
        # the noise of BLOCK measurements drawn at once, split by key in NOISE_KEYS order: the
        # same numbers as one draw per key and measurement from the same stream, at a fraction
        # of the cost of a call per measurement
        self._sigma_all = np.concatenate([self.sigma[key] for key in NOISE_KEYS])
        self.noisy = bool(np.any(self._sigma_all > 0))
        bounds = np.cumsum([0] + [self.sigma[key].size for key in NOISE_KEYS])
        self._slices = dict(zip(NOISE_KEYS, map(slice, bounds[:-1], bounds[1:]), strict=True))
        self._row = BLOCK  # next row of the current block (none drawn yet)

    @property
    def noise_slices(self) -> dict[str, slice]:
        """Where each key of :data:`NOISE_KEYS` sits in a row of :meth:`noise_block`."""
        return dict(self._slices)

    def noise_block(self) -> np.ndarray:
        """The noise of the next :data:`BLOCK` measurements, drawn from the sensors' stream:
        ``BLOCK x`` the keys' entries side by side (:attr:`noise_slices`). What
        :meth:`observe` draws; a runner that adds the noise itself (a lock-step run,
        :mod:`ffsm_pin.sim.lockstep`) calls it instead, never both."""
        return self.rng.standard_normal((BLOCK, self._sigma_all.size)) * self._sigma_all

    def _draw_block(self) -> None:
        z = self.noise_block()
        sl = self._slices
        self._q_b = z[:, sl["base_attitude"]]
        self._q_m = z[:, sl["joints"]]
        self._w = np.concatenate((z[:, sl["base_rate"]], z[:, sl["joint_rates"]]), axis=1)
        self._z_e = z[:, sl["ee_pose"]]
        self._z_e_dot = z[:, sl["ee_velocity"]]
        self._row = 0

    def observe(self, meas: Measurement) -> Measurement:
        """What the controller is given at ``meas.t`` for the exact measurement ``meas``."""
        if self.ideal:
            return meas
        if self.noisy:
            if self._row == BLOCK:
                self._draw_block()
            i = self._row
            self._row = i + 1
            q_b = meas.q_b + (self._q_b[i, 0] if self._scalar_base else self._q_b[i])
            fields = (
                q_b, meas.q_m + self._q_m[i], meas.w + self._w[i], meas.z_e + self._z_e[i],
                meas.z_e_dot + self._z_e_dot[i], meas.M, meas.h,
            )  # fmt: skip
            if self.spec.delay == 0:  # new arrays, handed out once: no copies needed
                return Measurement(meas.t, *fields)
        else:  # delay only
            fields = meas[1:]
        self.buffer.append(fields)
        # the oldest kept: k - d (or 0 early on), stamped with the current time; a copy of its
        # arrays, since a buffered measurement is handed out more than once and a controller
        # writing into one must not change what it is given later (M and h are read-only)
        q_b, q_m, w, z_e, z_e_dot, M, h = self.buffer[0]
        if not self._scalar_base:
            q_b = q_b.copy()
        return Measurement(meas.t, q_b, q_m.copy(), w.copy(), z_e.copy(), z_e_dot.copy(), M, h)
