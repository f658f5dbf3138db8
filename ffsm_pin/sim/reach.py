"""Where the reference leaves the arm's reach as the system CoM drifts (docs/model.md
section 7)."""

from __future__ import annotations

import numpy as np

from ..model import ReducedModel


class ReachWarning(UserWarning):
    """The reference leaves the arm's reach before the end of the run."""


REACH_SAMPLES = 100_000  # most samples of the reach scan; a longer run is scanned coarser


def reach_horizon(model: ReducedModel, theta_z, com0, reference, duration: float, dt=0.01):
    """First time at which the reference position is farther from the (drifting) system CoM
    than the arm can reach (sum of |V_k|), or None.

    Sampled every ``dt`` [s], or every ``duration / REACH_SAMPLES`` for runs longer than
    ``REACH_SAMPLES * dt`` (1000 s by default), so that the scan stays cheap however long the
    run.

    Parameters
    ----------
    model : ReducedModel
        The true model (its barycentric V_k).
    theta_z : ndarray
        Kinematic parameters; the first m2 are the CoM velocity v_0 [m/s].
    com0 : ndarray
        The system CoM at t = 0 [m].
    reference : Reference
        The task reference.
    duration : float
        The run's horizon [s].
    dt : float
        Sampling step [s].
    """
    m2 = model.m2
    reach = float(np.sum(np.linalg.norm(model.barycentric_V, axis=1)))  # type: ignore[attr-defined]
    dt = max(dt, duration / REACH_SAMPLES)
    ts = np.arange(0.0, duration + dt, dt)
    com = np.asarray(com0)[None, :m2] + ts[:, None] * np.asarray(theta_z[:m2])[None, :]
    ref = np.array([reference.ee_pose(t)[:m2] for t in ts])
    far = np.linalg.norm(ref - com, axis=1) > reach
    return float(ts[np.argmax(far)]) if far.any() else None
