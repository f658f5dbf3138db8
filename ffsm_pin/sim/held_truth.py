"""The true parameters after a capture (issue 40; docs/capture.md, "The true parameters after
a capture").

Before a capture the run's true parameters are the robot's (``theta_z``, ``theta_d``,
``theta_b`` of the recording, Eqs. 4, 12, 14). After the hand grasps the target, the plant is
the merged robot (robot + held body), and what an adaptive controller's estimates converge to,
if anywhere, is the merged robot's parameters: every V_k and every entry of theta_d move (the
mass fractions about the system CoM change, :mod:`ffsm_pin.control.held_body`), and v_0, A_0
become the whole system's CoM velocity and angular momentum about its CoM (constant from the
impact on: the target's momentum joined the robot's).

:func:`held_truth` computes them once, at the grasp, from the true held body (its
``pin.Inertia`` in the end-effector frame) and the merged robot's state after the impact.
:class:`HeldTruth` gives the run's signals ``theta_z_captured``, ``theta_d_captured``,
``theta_b_captured`` (constants, as the robot's) and the summary's ``final_theta_z_error``
and ``final_theta_d_error`` against them (it replaces the robot's, which a run with a capture
no longer tracks).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..control.held_body import held_body_increment, model_holding
from ..model import State
from ..robot import Robot
from .setup import Setup

__all__ = ["HELD_TRUTH_KEYS", "FinalErrors", "HeldTruth", "held_truth"]

#: The signals of the true parameters after a capture (constants, like ``theta_z``, ...).
HELD_TRUTH_KEYS = ("theta_z_captured", "theta_d_captured", "theta_b_captured")


@dataclass(frozen=True)
class FinalErrors:
    """The summary's final estimate errors against the merged robot's parameters.

    Attributes
    ----------
    errors : dict
        ``final_theta_z_error``, ``final_theta_d_error`` (those the run has).
    """

    errors: dict

    def summary(self) -> dict:
        """The summary.json keys (they replace the robot's own).

        Returns
        -------
        dict
            The errors.
        """
        return dict(self.errors)


@dataclass(frozen=True)
class HeldTruth:
    """The merged robot's true parameters after a capture.

    Attributes
    ----------
    theta_z : ndarray, shape (n_1,)
        col(v_0, V) of Eq. (4): the whole system's CoM velocity [m/s] after the impact and
        the merged robot's V_k [m].
    theta_d : ndarray, shape (n_2,)
        theta_d of Eq. (12), the merged robot's.
    theta_b : ndarray, shape (n_3,)
        col(A_0, theta_d) of Eq. (14): the whole system's angular momentum about its CoM
        [kg m^2/s] after the impact, and theta_d.
    m2 : int
        Position coordinates (the length of v_0).
    """

    theta_z: np.ndarray
    theta_d: np.ndarray
    theta_b: np.ndarray
    m2: int

    @property
    def momenta(self) -> tuple[np.ndarray, np.ndarray]:
        """(v_0 [m/s], A_0 [kg m^2/s]): the heads of theta_z and theta_b (copies)."""
        m3 = len(self.theta_b) - len(self.theta_d)
        return self.theta_z[: self.m2].copy(), self.theta_b[:m3].copy()

    def constants(self) -> dict[str, np.ndarray]:
        """The run's signals of the true parameters after the capture.

        Returns
        -------
        dict of str to ndarray
            :data:`HELD_TRUTH_KEYS` -> theta_z, theta_d, theta_b.
        """
        return dict(zip(HELD_TRUTH_KEYS, (self.theta_z, self.theta_d, self.theta_b), strict=True))

    def outcome(self, signals: Mapping[str, np.ndarray]) -> FinalErrors:
        """The run's summary keys against these parameters (:meth:`final_errors`).

        Parameters
        ----------
        signals : mapping of str to ndarray
            The run's signals.

        Returns
        -------
        FinalErrors
            The keys, for the run's outcomes.
        """
        return FinalErrors(self.final_errors(signals))

    def final_errors(self, signals: Mapping[str, np.ndarray]) -> dict:
        """The summary's ``final_theta_z_error`` and ``final_theta_d_error`` against the
        merged robot's parameters (none for an estimate the controller does not report).

        Parameters
        ----------
        signals : mapping of str to ndarray
            The run's signals (``theta_z_hat``, ``theta_d_hat``: rows).

        Returns
        -------
        dict
            The two keys whose estimate the run recorded, |estimate at the last row - truth|.
        """
        out = {}
        for name, truth in (("theta_z", self.theta_z), ("theta_d", self.theta_d)):
            key = f"{name}_hat"
            if key in signals and len(signals[key]):
                out[f"final_{name}_error"] = float(np.linalg.norm(signals[key][-1] - truth))
        return out


def held_truth(setup: Setup, held: pin.Inertia, merged: Robot, q, v) -> HeldTruth:
    """The true parameters of the robot of ``setup`` holding ``held``, with the whole
    system's momentum from the merged robot's state after the impact.

    Parameters
    ----------
    setup : Setup
        The run (its true robot, model and parameters).
    held : pin.Inertia
        The held body (the target) in the end-effector frame, as the merged robot adds it.
    merged : Robot
        The merged robot (the plant's after the capture).
    q, v : array_like
        Its configuration and velocity after the impact.

    Returns
    -------
    HeldTruth
        The merged robot's theta_z, theta_d, theta_b.
    """
    model = setup.model
    inc = held_body_increment(setup.robot, model, held)  # the body's change of V and theta_d
    theta_d = np.asarray(setup.theta_d) + inc.theta_d
    V = np.asarray(setup.theta_z)[model.m2 :] + inc.V
    st = State(merged).update(np.asarray(q, float), np.asarray(v, float))
    v0 = np.asarray(st.com_velocity, dtype=float).reshape(model.m2)
    A0 = np.asarray(st.angular_momentum, dtype=float).reshape(model.m3)
    return HeldTruth(np.concatenate((v0, V)), theta_d, np.concatenate((A0, theta_d)), model.m2)


def momenta_holding(robot: Robot, held: pin.Inertia, q, v) -> tuple[np.ndarray, np.ndarray]:
    """The whole system's (v_0, A_0) of ``robot`` holding ``held`` at (q, v): what the
    estimates' heads are set to at a grasp with ``[capture] estimates = "perturbed"`` (the
    drawn body in the hand, the true state; docs/capture.md). With the true held body it is
    the :class:`HeldTruth`'s :attr:`~HeldTruth.momenta`.

    Parameters
    ----------
    robot : Robot
        The robot before the capture (free-flyer root).
    held : pin.Inertia
        The held body in the end-effector frame.
    q, v : array_like
        The robot's configuration and velocity after the impact (Pinocchio convention).

    Returns
    -------
    v_0 : ndarray, shape (3,)
        The CoM velocity [m/s].
    A_0 : ndarray, shape (3,)
        The angular momentum about the CoM, world frame [kg m^2/s] (Eq. 14's head).
    """
    model = model_holding(robot, held)
    data = model.createData()
    hg = pin.computeCentroidalMomentum(model, data, np.asarray(q, float), np.asarray(v, float))
    mass = float(data.mass[0])
    return np.array(hg.linear) / mass, np.array(hg.angular)
