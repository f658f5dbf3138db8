"""The paper's schemes, what a robot needs for them, and what one period of its law returns.

Schemes (Section 4): ``"ppc"`` (case 1), ``"no-ppc"`` (case 2), ``"no-attitude"`` (case 3:
Eq. 81) and ``"known-model"`` (the baseline). :func:`check_feasibility` refuses a robot with
too few joints for a scheme's task; :class:`ControlOutput` and :class:`RowOutput` are what
:class:`~.controller.CoordinatedController` returns, on either backend.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import InfeasibleTaskError
from .funnel import FunnelEval

SCHEMES = ("ppc", "no-ppc", "no-attitude", "known-model")
TASK_SIZE = 3  # planar end-effector pose (x, y, attitude): m2 + m3
ATTITUDE_SIZE = 1  # planar base attitude: m3


class ControlOutput(NamedTuple):
    """Everything computed in one control period (values at the start of the period)."""

    u_m: np.ndarray  # joint torques [N m]
    w_mc: np.ndarray  # kinematic command [rad/s]
    w_mc_dot: np.ndarray  # its time derivative [rad/s^2]
    err_b: np.ndarray  # attitude error (m3) [rad or MRP]
    err_z: np.ndarray  # end-effector task error (task components) [m, rad or MRP]
    w_tilde: np.ndarray  # w - w-hat [rad/s]
    sigma_min: float
    damping: float
    funnel_b: FunnelEval | None = None  # numpy backend only (None for Eq. 81)
    funnel_z: FunnelEval | None = None  # numpy backend only
    # e of Eq. (54) with the true M and theta_d [N m s] (a diagnostic); None without theta_d_true
    e: np.ndarray | None = None
    # the period's signals at t as one row of CoordinatedController.signal_layout (w~, e, the
    # estimates and w-hat before the period advances them, w_mc, sigma_min, damping); None
    # without theta_d_true
    signals: np.ndarray | None = None


class RowOutput(NamedTuple):
    """What :meth:`CoordinatedController.step_row` returns.

    Attributes
    ----------
    u_m : ndarray
        The joint torques for the period [N m], shape ``(n_joints,)``.
    signals : ndarray
        The period's signals at its start, one row of
        :attr:`CoordinatedController.signal_layout` (w~, e of Eq. 54, the estimates and
        w-hat before the period advances them, w_mc, sigma_min, the damping).
    """

    u_m: np.ndarray
    signals: np.ndarray


def check_feasibility(
    n_joints: int, scheme: str, *, n_task: int = TASK_SIZE, m3: int = ATTITUDE_SIZE
) -> None:
    """Refuse a robot whose joints cannot serve the task (plus the attitude, if regulated).

    Eq. (25) needs H_bm (m3 x m1) of full row rank and Eq. (36) needs J_m U (n_task x m1) of
    full row rank: m1 >= n_task + m3 (docs/model.md section 5, docs/spatial.md); m1 >= n_task
    for Eq. (81), which does not regulate the attitude.

    Parameters
    ----------
    n_joints : int
        Joints of the robot, m1.
    scheme : str
        One of :data:`SCHEMES`.
    n_task : int
        Task components.
    m3 : int
        Attitude coordinates.
    """
    if scheme not in SCHEMES:
        raise InfeasibleTaskError(f"unknown scheme {scheme!r}; valid choices: {SCHEMES}")
    att = 0 if scheme == "no-attitude" else m3
    need = n_task + att
    if n_joints < need:
        what = f"the {n_task}-component end-effector task" + (
            "" if not att else f" plus the {m3}-component base attitude"
        )
        raise InfeasibleTaskError(
            f"scheme {scheme!r} needs at least {need} manipulator joints for {what} "
            f"({n_task} task + {att} attitude), the robot has {n_joints}"
        )


__all__ = [
    "ATTITUDE_SIZE", "SCHEMES", "TASK_SIZE", "ControlOutput", "RowOutput", "check_feasibility",
]  # fmt: skip
