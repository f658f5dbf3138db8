"""The actuator and sensor tables of a scenario: what a user asks of the devices between the
controller and the plant (``[actuators]``, ``[sensors]``, docs/cli.md).

The devices themselves (:class:`~ffsm_pin.sim.actuators.Actuators`,
:class:`~ffsm_pin.sim.sensors.Sensors`) are part of the run, in :mod:`ffsm_pin.sim`; these
frozen dataclasses only hold the options, with their defaults (all off: ideal actuators, exact
and undelayed measurements).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LIMIT_WORDS = ("none", "urdf")


@dataclass(frozen=True)
class ActuatorSpec:
    """The ``[actuators]`` table (all off by default).

    Attributes
    ----------
    torque_limit : str or float or tuple of float
        ``"none"``, ``"urdf"`` (each joint's ``<limit effort>``), a number or one per joint [N m].
    rate_limit : float or tuple of float
        Largest change of the applied torque, a number or one per joint [N m/s]; 0 = none.
    time_constant : float
        First-order lag of the applied torque [s]; 0 = none.
    torque_noise : float or tuple of float
        Standard deviation of additive Gaussian torque noise, a number or one per joint [N m].
    seed : int
        Seed of the torque noise.
    """

    torque_limit: str | float | tuple[float, ...] = "none"
    rate_limit: float | tuple[float, ...] = 0.0
    time_constant: float = 0.0
    torque_noise: float | tuple[float, ...] = 0.0
    seed: int = 0

    @property
    def ideal(self) -> bool:
        """True when the actuators apply the command unchanged."""
        return (
            self.torque_limit == "none"
            and not np.any(self.rate_limit)
            and self.time_constant == 0
            and not np.any(self.torque_noise)
        )


# [sensors.noise] keys, in the order the noise is drawn
NOISE_KEYS = ("joints", "joint_rates", "base_attitude", "base_rate", "ee_pose", "ee_velocity")


@dataclass(frozen=True)
class SensorSpec:
    """The ``[sensors]`` table (exact and undelayed by default).

    Attributes
    ----------
    seed : int
        Seed of the noise streams.
    delay : int
        Control periods between a measurement and its use (>= 0).
    noise : tuple of (str, float or tuple of float)
        ``(key, standard deviation)`` pairs, key in :data:`NOISE_KEYS`; a number or one value
        per component [rad, rad/s, rad or MRP, rad/s, m and rad or MRP, m/s and rad/s or 1/s].
    """

    seed: int = 0
    delay: int = 0
    noise: tuple[tuple[str, float | tuple[float, ...]], ...] = ()

    @property
    def ideal(self) -> bool:
        """True when the controller sees the exact measurement."""
        return self.delay == 0 and not any(np.any(v) for _, v in self.noise)
