"""How the paper's controller stops a run, and its singularity bookkeeping.

A run stops in a controlled way (:class:`~ffsm_pin.errors.SimulationError`, with time and
cause) when a funnel whose transformation the scheme uses is left (built by the controller,
which knows its funnels: :meth:`~.controller.CoordinatedController.funnel_stop`), when an
estimate degenerates (:func:`collapse_stop`, :func:`inertia_stop`), when a torque becomes
non-finite (:func:`nonfinite_stop`), or when the arm stays near a singularity longer than the
policy allows (:class:`SingularityWatch`, which also announces damping with a
:class:`SingularityWarning`). The numpy reference and the compiled period stop alike.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import SimulationError
from .gains import SingularityPolicy


class SingularityWarning(UserWarning):
    """The damped pseudo-inverse of the kinematic law became active."""


def component_names(m2: int, m3: int) -> tuple[str, ...]:
    """Names of the end-effector task components (pose order: position, then attitude).

    Parameters
    ----------
    m2, m3 : int
        Position and attitude coordinates.

    Returns
    -------
    tuple of str
        One name per task component.
    """
    if m3 == 1:
        return ("x", "y", "attitude")[:m2] + ("attitude",)
    return ("x", "y", "z")[:m2] + ("s1", "s2", "s3")[:m3]


def collapse_stop(t: float, h_norm: float) -> SimulationError:
    """theta_b-hat collapsed: |H_bm-hat| ~ 0 and Eq. (25) undefined.

    Parameters
    ----------
    t : float
        Time [s].
    h_norm : float
        abs(H_bm-hat).

    Returns
    -------
    SimulationError
        The stop, cause ``"estimate"``.
    """
    return SimulationError(
        f"t = {t:.4f} s: the estimate theta_b-hat collapsed (|H_bm-hat| = {h_norm:.3g}); "
        "Eq. (25) is undefined",
        time=t,
        cause="estimate",
    )


def nonfinite_stop(t: float) -> SimulationError:
    """The joint torque became non-finite."""
    return SimulationError(
        f"t = {t:.4f} s: the joint torque became non-finite", time=t, cause="nonfinite"
    )


def inertia_stop(t: float) -> SimulationError:
    """M(q, theta_d-hat) is not positive definite: the filter (46) is undefined."""
    return SimulationError(
        f"t = {t:.4f} s: the estimated inertia M(q, theta_d-hat) is not positive definite; "
        "the filter (46) is undefined",
        time=t,
        cause="estimate",
    )


def physical_stop(t: float, max_iter: int) -> SimulationError:
    """The projection of theta_d-hat onto the physical set (``adaptation = "physical"``,
    :mod:`.physical`) did not reach the margin within its cap of half-space projections.

    Parameters
    ----------
    t : float
        Time [s].
    max_iter : int
        The cap.

    Returns
    -------
    SimulationError
        The stop, cause ``"estimate"``.
    """
    return SimulationError(
        f"t = {t:.4f} s: theta_d-hat stays outside the physical set after {max_iter} "
        "projections (adaptation = 'physical'); the estimate is not physical",
        time=t,
        cause="estimate",
    )


def base_row_stop(t: float, m3: int) -> SimulationError:
    """The base row(s) of the filter's Eqs. (60a), (64)-(65) are singular.

    Parameters
    ----------
    t : float
        Time [s].
    m3 : int
        Attitude coordinates (rows of the base).

    Returns
    -------
    SimulationError
        The stop, cause ``"singular"``.
    """
    what = "base row of the filter is" if m3 == 1 else "base rows of the filter are"
    return SimulationError(f"t = {t:.4f} s: {what} singular", time=t, cause="singular")


class SingularityWatch:
    """Damped least squares over the periods of a run, against the policy.

    Parameters
    ----------
    policy : SingularityPolicy
        The :class:`~.gains.SingularityPolicy` (threshold [m], ``max_damped_time`` [s]).
    events : list of str
        The controller's events, where the warning's text is appended.
    """

    def __init__(self, policy: SingularityPolicy, events: list[str]):
        self.policy = policy
        self.events = events
        #: the time [s] since which every period was damped, or None
        self.since: float | None = None
        self._last_warning = -np.inf

    def update(self, t: float, sigma_min: float, damping: float, stacklevel: int) -> None:
        """Book the period at ``t`` [s] with its sigma_min and damping: a warning when damping
        starts (at most one a second; ``stacklevel`` as :func:`warnings.warn`'s, counted from
        the caller of this method), a stop when it lasted longer than the policy allows.

        Parameters
        ----------
        t : float
            Time of the period [s].
        sigma_min : float
            Smallest singular value of the law's matrix [m].
        damping : float
            The damping lambda^2 applied (0: none).
        stacklevel : int
            As :func:`warnings.warn`'s, counted from the caller.
        """
        thr = self.policy.threshold
        if damping > 0:
            if self.since is None:
                self.since = t
                if t - self._last_warning > 1.0:
                    msg = (
                        f"t = {t:.3f} s: the arm is near a singularity (sigma_min = "
                        f"{sigma_min:.4f} < {thr}); damped least squares is active"
                    )
                    self.events.append(msg)
                    warnings.warn(msg, SingularityWarning, stacklevel=stacklevel + 1)
                    self._last_warning = t
            elif t - self.since > self.policy.max_damped_time:
                raise SimulationError(
                    f"t = {t:.3f} s: the arm stayed singular for more than "
                    f"{self.policy.max_damped_time} s (sigma_min = {sigma_min:.4f} < {thr} since "
                    f"t = {self.since:.3f} s)",
                    time=t,
                    cause="singular",
                )
        else:
            self.since = None


__all__ = [
    "SingularityWarning", "SingularityWatch", "base_row_stop", "collapse_stop",
    "component_names", "inertia_stop", "nonfinite_stop", "physical_stop",
]  # fmt: skip
