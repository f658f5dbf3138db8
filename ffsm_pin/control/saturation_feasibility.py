"""Torque feasibility of the funnels: whether the actuators' limits allow the motion the
prescribed funnels and the reference ask for (``--check``; docs/saturation.md).

Two accelerations of each funnel-bounded row (base attitude, end-effector task) are asked
for, from the start at rest:

* **reach**: the error of a robot that stayed where it is, ``d(t) = error(z(0), z_d(t))``, must
  be brought inside the funnel, ``lower rho(t) < e(t) < upper rho(t)``. From rest with
  ``|dd z / dt^2| <= A`` the row moves at most ``A t^2 / 2`` by time t, so it is necessary that
  ``A >= max_t 2 excess(t) / t^2``, ``excess = max(d - upper rho, lower rho - d)``
  (:func:`reach_acceleration`);
* **follow**: the reference's own acceleration, ``max_t |dd z_d / dt^2|``, which the row has to
  match once the error is inside the funnel's final width.

The larger of the two is the row's demand ``a``. At the initial configuration, with the base
unactuated (``M dw/dt = (0, u)`` at rest), joint accelerations dw_m/dt cost the torque
``M* dw_m/dt``, ``M* = M_mm - M_mb M_bb^-1 M_bm``, and move the rows at ``G dw_m/dt``,
``G = [L_b (-M_bb^-1 M_bm); J_m - J_b M_bb^-1 M_bm]`` (:func:`row_map`). The least-norm joint
acceleration of a row's demand costs ``M* G^+ e_i a_i``; the rows ask in either direction and
at different times, so joint j needs up to ``sum_i |(M* G^+)_ji| a_i``
(:func:`torque_needed`), compared with its limit. What is the same for every robot is here;
what a geometry gives is its (M, J, L_b) at the initial state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def reach_acceleration(distance, rho, lower, upper, ts) -> tuple[np.ndarray, np.ndarray]:
    """The acceleration each row needs to bring the error of a robot at rest inside its
    funnel, and when it is needed most (module docstring).

    Parameters
    ----------
    distance : array_like, shape (T, r)
        d(t): the error at ``ts`` if the robot stayed at its initial pose.
    rho : array_like, shape (T, r)
        rho(t) of each row's funnel at ``ts``.
    lower, upper : array_like, shape (r,)
        The funnel's sides in units of rho (-sigma and 1, or -1 and sigma).
    ts : array_like, shape (T,)
        The times [s], all > 0.

    Returns
    -------
    accel : ndarray, shape (r,)
        max(0, max_t 2 excess(t) / t^2) [row units / s^2].
    t_worst : ndarray, shape (r,)
        The time of that maximum [s] (nan where nothing is needed).
    """
    d, r = np.asarray(distance, dtype=float), np.asarray(rho, dtype=float)
    t = np.asarray(ts, dtype=float)[:, None]
    excess = np.maximum(d - np.asarray(upper) * r, np.asarray(lower) * r - d)
    ratio = 2.0 * excess / t**2
    k = np.argmax(ratio, axis=0)
    best = ratio[k, np.arange(ratio.shape[1])]
    need = best > 0.0
    return np.where(need, best, 0.0), np.where(need, t[k, 0], np.nan)


def row_map(M, J, L_b, m3: int, attitude: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M*, G, B): joint torque per joint acceleration, the funnel rows' acceleration per
    joint acceleration, and the base's, at rest with the base unactuated (module docstring).

    Parameters
    ----------
    M : array_like, shape (m3 + n, m3 + n)
        The reduced inertia (base rows first).
    J : array_like, shape (n_task, m3 + n)
        The task Jacobian of Eq. (3) over (w_b, w_m).
    L_b : array_like, shape (m3, m3)
        The attitude matrix of Eq. (1).
    m3 : int
        Attitude coordinates.
    attitude : bool
        Whether the base attitude rows are funnel rows (first in G).

    Returns
    -------
    M_star : ndarray, shape (n, n)
        M_mm - M_mb M_bb^-1 M_bm.
    G : ndarray, shape (r, n)
        The rows' accelerations per joint acceleration.
    B : ndarray, shape (m3, n)
        -M_bb^-1 M_bm: the base's angular acceleration (and, without angular momentum, rate)
        per joint acceleration (rate).
    """
    M, J = np.asarray(M, dtype=float), np.asarray(J, dtype=float)
    B = -np.linalg.solve(M[:m3, :m3], M[:m3, m3:])
    M_star = M[m3:, m3:] + M[m3:, :m3] @ B
    task = J[:, m3:] + J[:, :m3] @ B
    G = np.vstack((np.asarray(L_b, dtype=float) @ B, task)) if attitude else task
    return M_star, G, B


def along_reference(maps, rates, q_b, q_m, ts) -> tuple[np.ndarray, list]:
    """The configurations a robot passes that moves its rows at ``rates`` from (q_b, q_m)
    without angular momentum, and (M*, G) at each (explicit Euler steps between the times
    ``ts``; the least-norm joint rates G^+ rates, the base turning by B).

    Parameters
    ----------
    maps : callable
        ``maps(q_b, q_m)`` -> (M*, G, B, L_b) of the geometry at a configuration
        (:func:`row_map` and the attitude matrix).
    rates : callable
        ``rates(t, q_b, q_m)`` -> the rows' rates (r,) there (the reference's, with its
        error decaying, say).
    q_b : float or ndarray
        The initial base attitude [rad] or MRP.
    q_m : ndarray, shape (n,)
        The initial joint angles [rad].
    ts : ndarray, shape (T,)
        The times [s], increasing.

    Returns
    -------
    q_ms : ndarray, shape (T, n)
        The joint angles at ``ts``.
    mapped : list of tuple
        (M*, G) at each time.
    """
    q_b, q_m = np.array(q_b, dtype=float), np.array(q_m, dtype=float)
    q_ms, mapped = [], []
    for t, h in zip(ts, np.diff(ts, append=ts[-1]), strict=True):
        M_star, G, B, L_b = maps(q_b, q_m)
        q_ms.append(q_m.copy())
        mapped.append((M_star, G))
        w_m = np.linalg.pinv(G) @ rates(t, q_b, q_m)
        q_m = q_m + h * w_m
        q_b = np.reshape(q_b + h * (L_b @ (B @ w_m)), np.shape(q_b))
    return np.array(q_ms), mapped


def torque_needed(M_star, G, accel) -> np.ndarray:
    """Each joint's torque for the rows' demands ``accel``, each in its worse direction:
    ``|M* G^+| accel`` (joints x rows, before the sum over rows) [N m].

    Parameters
    ----------
    M_star : array_like, shape (n, n)
        :func:`row_map`'s M*.
    G : array_like, shape (r, n)
        :func:`row_map`'s G.
    accel : array_like, shape (r,)
        The rows' demands [row units / s^2].

    Returns
    -------
    ndarray, shape (n, r)
        Joint j's torque for row i's demand; summed over i, the joint's need.
    """
    per_row = np.asarray(M_star, dtype=float) @ np.linalg.pinv(np.asarray(G, dtype=float))
    return np.abs(per_row) * np.asarray(accel, dtype=float)


@dataclass(frozen=True)
class TorqueFeasibility:
    """The condition's numbers for one run (``--check``).

    Attributes
    ----------
    rows : tuple of str
        The funnel rows: ``("b", 0)``-like labels ``"b0"``, ``"z1"`` (funnel, component).
    reach, follow : ndarray, shape (r,)
        The two demands of each row [row units / s^2] (module docstring).
    t_reach : ndarray, shape (r,)
        When the reach demand is largest [s] (nan where none).
    share : ndarray, shape (n, r)
        :func:`torque_needed` of max(reach, follow) at the worst configuration along the
        reference (:func:`along_reference`: the largest need-to-limit ratio).
    limit : ndarray, shape (n,)
        The torque limits [N m], inf where none.
    t_config : float
        The reference's time of that configuration [s] (0: the initial one).
    """

    rows: tuple[str, ...]
    reach: np.ndarray
    follow: np.ndarray
    t_reach: np.ndarray
    share: np.ndarray
    limit: np.ndarray
    t_config: float = 0.0

    @property
    def needed(self) -> np.ndarray:
        """Each joint's need [N m] (the sum of its :attr:`share` over the rows)."""
        return self.share.sum(axis=1)

    def problem(self, joint_names) -> str | None:
        """The warning's text naming the joint with the largest need-to-limit ratio, the row
        that asks most of it and the key that relaxes that row; None when every joint's need
        is within its limit.

        Parameters
        ----------
        joint_names : sequence of str
            The joints' names.

        Returns
        -------
        str or None
            One line, or None.
        """
        ratio = self.needed / self.limit
        j = int(np.argmax(ratio))
        if not ratio[j] > 1.0:
            return None
        i = int(np.argmax(self.share[j]))
        funnel, comp = self.rows[i][0], int(self.rows[i][1:])
        if self.reach[i] >= self.follow[i]:
            why = (
                f"to bring its error inside the funnel by t = {self.t_reach[i]:.3g} s; slow "
                f"controller.funnel.beta_{funnel} or widen rho_{funnel}0 / rho_{funnel}inf "
                f"(component {comp})"
            )
        else:
            why = "to follow the reference; slow reference.ee (its amplitudes or frequencies)"
        return (
            f"torque feasibility: joint {joint_names[j]!r} needs about {self.needed[j]:.4g} N m "
            f"in the configuration of t = {self.t_config:.3g} s along the reference, "
            f"{ratio[j]:.3g} x its actuators.torque_limit "
            f"{self.limit[j]:.4g} N m; most of it for funnel row {funnel}[{comp}] "
            f"({max(self.reach[i], self.follow[i]):.3g} /s^2 {why}), or raise the limit"
        )


__all__ = [
    "TorqueFeasibility", "along_reference", "reach_acceleration", "row_map", "torque_needed",
]  # fmt: skip
