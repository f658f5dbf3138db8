"""Joint actuators between the controller and the plant: limits, lag and noise.

The controller commands ``u_cmd``; the actuators apply ``u_m`` to the plant, once per control
period dt (held over the plant's substeps). With every option off (the default) ``u_m`` is
``u_cmd`` itself. Otherwise, with L the torque limit, r the rate limit, tau the time
constant and x the actuator's torque state (x = 0 at t = 0)::

    y   = clip(u_cmd, -L, L)                      # saturation
    y   = x + (1 - exp(-dt / tau)) (y - x)        # lag tau dx/dt = y - x, exact for held y
    x  <- x + clip(y - x, -r dt, r dt)             # rate limit
    u_m = clip(x + n, -L, L),  n ~ N(0, sigma^2)   # torque noise, seeded; never beyond L

See docs/controllers.md, "Actuators".
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ParameterError, ScenarioError, expected_count
from ..scenario.devices import ActuatorSpec
from ._actuator_kernel import actuate


def per_joint(value, n: int, key: str, joints: tuple[str, ...] = ()) -> np.ndarray:
    """A number or one value per joint, as an (n,) array; ParameterError naming ``key``.

    Parameters
    ----------
    value : float or array_like
        A number or one per joint.
    n : int
        Number of joints.
    key : str
        The scenario key, for the message.
    joints : tuple of str
        Joint names, for the message.

    Returns
    -------
    ndarray, shape (n,)
        The values.
    """
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        names = f" ({', '.join(joints)})" if joints else ""
        raise ParameterError(
            f"{key}: {arr.size} values, expected {expected_count(n)}, one per joint{names}"
        )
    if np.any(arr < 0) or not np.all(np.isfinite(arr) | (arr == np.inf)):
        raise ParameterError(f"{key} = {arr.tolist()}: must be >= 0")
    return arr


def urdf_limits(effort: np.ndarray | None, n: int, joints: tuple[str, ...] = ()) -> np.ndarray:
    """The torque limits of ``torque_limit = "urdf"``: each joint's URDF effort limit [N m].

    Parameters
    ----------
    effort : ndarray or None
        Each joint's effort limit, NaN where the URDF gives none
        (:attr:`~ffsm_pin.robot.Robot.effort_limits`); None: none known.
    n : int
        Number of joints.
    joints : tuple of str
        Joint names, for the message.

    Raises
    ------
    ScenarioError
        A joint without a finite effort limit > 0, naming the joints and what to give instead.

    Returns
    -------
    ndarray, shape (n,)
        The limits [N m].
    """
    eff = np.full(n, np.nan) if effort is None else np.asarray(effort, dtype=float).copy()
    names = joints if len(joints) == n else tuple(f"joint {i + 1}" for i in range(n))
    bad = [name for name, e in zip(names, eff, strict=True) if not (e > 0 and np.isfinite(e))]
    if bad:
        which = ", ".join(repr(name) for name in bad)
        raise ScenarioError(
            f"actuators.torque_limit = 'urdf': {which} "
            f"{'has' if len(bad) == 1 else 'have'} no effort limit > 0 in the URDF "
            "(<limit effort=...>); give the limits as numbers instead: [actuators] "
            f"torque_limit = 50.0, or a list of {n} [N m]"
        )
    return eff


BLOCK = 1024  # control periods whose torque noise is drawn in one call


class Actuators:
    """The actuator model of :class:`ActuatorSpec` for ``n`` joints and control period ``dt``.

    Parameters
    ----------
    spec : ActuatorSpec
        The ``[actuators]`` table.
    n : int
        Number of joints.
    dt : float
        Control period [s].
    effort : ndarray or None
        Each joint's URDF effort limit [N m], NaN where the URDF gives none (needed for
        ``torque_limit = "urdf"``, :func:`urdf_limits`).
    joints : tuple of str
        Joint names, for messages.
    """

    def __init__(
        self,
        spec: ActuatorSpec,
        n: int,
        dt: float,
        effort: np.ndarray | None = None,
        joints: tuple[str, ...] = (),
    ):
        self.spec, self.n = spec, n
        self.ideal = spec.ideal
        if spec.torque_limit == "none":
            self.limit = np.full(n, np.inf)
        elif spec.torque_limit == "urdf":
            self.limit = urdf_limits(effort, n, joints)
        elif isinstance(spec.torque_limit, str):
            raise ParameterError(
                f"actuators.torque_limit = {spec.torque_limit!r} unknown; valid choices: "
                "'none', 'urdf', a number or one number per joint [N m]"
            )
        else:
            self.limit = per_joint(spec.torque_limit, n, "actuators.torque_limit", joints)
            if np.any(self.limit == 0):
                raise ParameterError("actuators.torque_limit: must be > 0 (use 'none' for none)")
        rate = per_joint(spec.rate_limit, n, "actuators.rate_limit", joints)
        self.max_change = np.where(rate > 0, rate * dt, np.inf)  # [N m] per control period
        if spec.time_constant < 0 or not np.isfinite(spec.time_constant):
            raise ParameterError(f"actuators.time_constant = {spec.time_constant}: must be >= 0")
        self.alpha = 1.0 - np.exp(-dt / spec.time_constant) if spec.time_constant > 0 else 1.0
        self.sigma = per_joint(spec.torque_noise, n, "actuators.torque_noise", joints)
        self.noisy = bool(np.any(self.sigma > 0))
        self.rng = np.random.default_rng(spec.seed)
        self.x = np.zeros(n)  # the actuators' torque state [N m]
        # which steps act (a step that cannot change anything is skipped: same numbers, faster)
        self.limited = bool(np.any(np.isfinite(self.limit)))
        self.lagged = self.alpha != 1.0
        self.rate_limited = bool(np.any(np.isfinite(self.max_change)))
        self._low, self._low_change = -self.limit, -self.max_change
        self._row = BLOCK  # next row of the current block of torque noise (none drawn yet)
        self._zeros = np.zeros(n)
        self.last_saturated = False  # some joint at its limit in the last applied period
        self.saturated_periods = np.zeros(n, dtype=np.int64)  # per joint: periods at its limit
        self._kernel = actuate  # the compiled step (numba)
        if not self.ideal:  # compile (or load) it before the run
            self._kernel(
                np.zeros(n), self.x.copy(), self.limit, self.alpha, self.lagged,
                self.max_change, self.rate_limited, self._zeros, np.empty(n),
            )  # fmt: skip

    def apply(self, u_cmd: np.ndarray) -> np.ndarray:
        """The torque applied this control period for the command ``u_cmd`` [N m]; sets
        :attr:`last_saturated`. The compiled step, tested equal bit for bit to
        :meth:`apply_reference`."""
        if self.ideal:
            self.last_saturated = False
            return u_cmd
        out = np.empty(self.n)
        self.last_saturated = self._kernel(
            np.asarray(u_cmd, dtype=float), self.x, self.limit, self.alpha, self.lagged,
            self.max_change, self.rate_limited, self._next_noise(), out,
        )  # fmt: skip
        if self.last_saturated:  # (the kernel's test, joint by joint)
            self.saturated_periods += np.abs(out) >= self.limit
        return out

    def _next_noise(self) -> np.ndarray:
        """The torque noise of this period [N m] (zeros without noise); BLOCK periods are drawn at
        once, the same numbers as one draw per period from the same stream."""
        if not self.noisy:
            return self._zeros
        if self._row == BLOCK:
            self._noise = self.rng.standard_normal((BLOCK, self.n)) * self.sigma
            self._row = 0
        self._row += 1
        return self._noise[self._row - 1]

    def apply_reference(self, u_cmd: np.ndarray) -> np.ndarray:
        """The readable numpy version of :meth:`apply` (updates the torque state ``x``)."""
        # min(max(.)) is np.clip, without its overhead on short vectors
        y = np.minimum(np.maximum(u_cmd, self._low), self.limit) if self.limited else u_cmd
        if self.lagged:
            y = self.x + self.alpha * (y - self.x)
        if self.rate_limited:
            y = self.x + np.minimum(np.maximum(y - self.x, self._low_change), self.max_change)
        self.x = y
        if not self.noisy:
            return y
        u = y + self._next_noise()
        return np.minimum(np.maximum(u, self._low), self.limit) if self.limited else u

    def saturation_per_joint(self, periods: int) -> list[float]:
        """Per joint, the share of ``periods`` control periods it spent at its torque limit
        (counted by :meth:`apply`)."""
        return (self.saturated_periods / max(periods, 1)).tolist()

    def saturation_of_rows(self, blocks: Callable) -> tuple[float, list[float]]:
        """The saturation fraction and its share per joint from recorded applied torques (a
        recovered run): a row counts when a joint is at its limit, the test of :meth:`apply`,
        so the fractions are the loop's when every period was recorded (a sample of the
        periods otherwise).

        Parameters
        ----------
        blocks : callable
            keys -> iterator of row blocks (``Signals.blocks``) with ``u_m``.

        Returns
        -------
        fraction : float
            Rows with some joint at its limit, over the rows (NaN without rows).
        per_joint : list of float
            Per joint, rows at its limit over the rows.
        """
        rows, any_at, per_joint = 0, 0, np.zeros(self.n, dtype=np.int64)
        for b in blocks(["u_m"]):
            at = np.abs(b["u_m"]) >= self.limit
            any_at += int(np.count_nonzero(at.any(axis=1)))
            per_joint += np.count_nonzero(at, axis=0)
            rows += len(at)
        if not rows:
            return float("nan"), [float("nan")] * self.n
        return any_at / rows, (per_joint / rows).tolist()

    def saturated(self, u_m: np.ndarray) -> bool:
        """Some joint's applied torque is at its limit."""
        return self.limited and bool((np.abs(u_m) >= self.limit).any())
