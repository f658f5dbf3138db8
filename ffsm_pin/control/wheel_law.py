"""The paper's controller with reaction wheels after a capture (issue 40; our extension, not
the paper's: docs/capture.md, "The paper's controller with the wheels").

``[controller.params] wheels = "after-capture"`` gives ``lu-jia`` the optional
``wheel_torque(meas)`` output (docs/controllers.md): zero until the grasp, then the wheels take
the bus attitude from the arm. At the grasp the law lets the base attitude go (Eq. 81, the
scheme "no-attitude"'s kinematic law: ``CompiledPeriod.release_attitude``), so that the arm
serves the hand's task alone and comes to rest relative to the bus once the wheels hold the
bus (the detumble); the wheel torques turn the bus back to ``reference.base_attitude``:

    tau_w = A^+ I_b (omega^2 phi + 2 omega w_b),

phi the rotation vector of the bus attitude error and w_b the measured bus rate (bus frame),
A the wheels' axes, I_b = R_b^T H_bb-hat R_b the system's inertia about its CoM as the bus sees
it with the joints locked (H_bb of Eq. 14 at the estimates theta_b-hat; so the held body's
share once it joined them), omega the base funnel's decay rate (the largest beta_b [1/s]):
a critically damped attitude loop at the rate the performance specification already asks of
the base error. Nothing is tuned to a robot.

The wheels store angular momentum the paper's model does not know: the robot's own momentum
about the system CoM is L - R_b A h, no longer constant once the wheels turn. The law's base
rows use the estimate A_0-hat of it (the head of theta_b-hat, Eq. 14), so each period the
law moves A_0-hat by the change of R_b A h it commands, -R_b A dh with dh the torque the
wheels will apply over the period times dt (``Wheels.limit``: the commanded torque as the
wheels' limits cut it, from the momenta the law has commanded so far). The adaptation goes on
from there (the estimate stays an estimate); the arrays are the ones both backends read.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from ..attitude.mrp import to_rotation
from ..errors import ParameterError
from ..robot.wheels import Wheels
from .interface import Measurement

__all__ = ["WHEEL_MODES", "BaseWheelLaw", "wheel_mode"]

#: ``[controller.params] wheels`` of lu-jia: no wheel torque, or the law above after a grasp.
WHEEL_MODES = ("none", "after-capture")


def wheel_mode(params: Mapping, wheels: Wheels | None) -> str:
    """``[controller.params] wheels``, checked: ``"none"`` (the default) or
    ``"after-capture"``, which needs ``[robot.satellite.wheels]``.

    Parameters
    ----------
    params : mapping
        The ``[controller.params]`` table.
    wheels : Wheels or None
        The scenario's wheels.

    Returns
    -------
    str
        The mode.

    Raises
    ------
    ParameterError
        An unknown mode, or ``"after-capture"`` without wheels.
    """
    mode = params.get("wheels", "none")
    if mode not in WHEEL_MODES:
        raise ParameterError(
            f"controller.params.wheels = {mode!r}: valid choices: "
            + ", ".join(repr(m) for m in WHEEL_MODES)
        )
    if mode != "none" and wheels is None:
        raise ParameterError(
            f"controller.params.wheels = {mode!r} needs [robot.satellite.wheels]; give the "
            "wheels or wheels = 'none'"
        )
    return str(mode)


class BaseWheelLaw:
    """The wheel torques of ``lu-jia`` after a capture (module docstring).

    Parameters
    ----------
    wheels : Wheels
        The bus's wheels (axes, limits).
    base_attitude : ndarray, shape (3,)
        The desired bus attitude (MRP), ``reference.base_attitude``.
    rate : float
        omega [1/s], the base funnel's decay rate.
    law : CoordinatedController
        The law: its model and estimates (theta_b-hat, moved in place).
    dt : float
        The control period [s].
    """

    def __init__(self, wheels: Wheels, base_attitude, rate: float, law, dt: float) -> None:
        self.wheels = wheels
        self.R_d = to_rotation(np.asarray(base_attitude, dtype=float))
        self.omega = float(rate)
        self.law = law
        self.dt = float(dt)
        self.h = np.zeros(wheels.n)  # the momenta commanded so far [N m s]
        self.active = False  # from the grasp on

    def start(self) -> None:
        """Act from now on (the loop's capture hook, at the grasp): the wheels take the bus
        attitude and the arm lets it go (:meth:`~.compiled_period.CompiledPeriod.release_attitude`,
        Eq. 81)."""
        self.active = True
        self.law.release_attitude()

    def torque(self, meas: Measurement) -> np.ndarray:
        """The period's wheel torques [N m] (zero before the grasp); moves A_0-hat by the
        momentum they will store.

        Parameters
        ----------
        meas : Measurement
            What the controller saw this period (``q_b``, ``q_m``, ``w``).

        Returns
        -------
        ndarray, shape (N,)
            The commanded torques [N m].
        """
        if not self.active:
            return np.zeros(self.wheels.n)
        law = self.law
        q_b = np.asarray(meas.q_b, dtype=float)
        R = to_rotation(q_b)
        phi = pin.log3(self.R_d.T @ R)  # bus attitude error, bus frame [rad]
        w_bus = R.T @ np.asarray(meas.w[:3], dtype=float)
        H_bb = law.model.momentum_matrices(law.theta_b, q_b, np.asarray(meas.q_m, float))[0]
        I_bus = R.T @ np.asarray(H_bb, dtype=float) @ R  # Eq. (14)'s H_bb in the bus frame
        w = self.omega
        tau = self.wheels.allocation @ (I_bus @ (w * w * phi + 2.0 * w * w_bus))
        applied = self.wheels.limit(self.h, tau, self.dt)
        dh = applied * self.dt
        # the robot's own momentum, Eq. (14)'s A_0: less what the wheels store, R_b A dh
        law.theta_b[: law.m3] -= R @ self.wheels.momentum_bus(dh)
        self.h = self.h + dh
        return tau
