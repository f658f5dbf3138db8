"""Prescribed-performance funnels and the error transformation (Eqs. 16-24).

Element-wise, for an error e_i(t) with performance function
``rho_i(t) = (rho0_i - rhoinf_i) exp(-beta_i t) + rhoinf_i`` (Eq. 18), the constraint is
(Eq. 16/17)::

    -sigma_i rho_i < e_i < rho_i        if e_i(0) >= 0
    -rho_i < e_i < sigma_i rho_i        if e_i(0) < 0

and with ``s = e / rho`` the transformation (Eq. 21) is::

    R(s) = ln((sigma + s) / (sigma - sigma s))       if e_i(0) >= 0
    R(s) = ln((sigma + sigma s) / (sigma - s))       if e_i(0) < 0

``psi = R(s)`` (Eq. 20), ``Phi = dR/ds / rho`` (Eq. 22), so that
``dpsi/dt = Phi (de/dt - drho/dt s)``. The logarithm is refused outside the funnel
(:class:`FunnelExit`); the caller decides what happens then.

:class:`Funnel` evaluation is written with plain arithmetic so that it also works on
complex numbers (the controller differentiates through it by complex step).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError


class FunnelExit(Exception):
    """An error component left its funnel: psi is undefined there.

    Parameters
    ----------
    index : int
        The component that left.
    value : float
        Its error [error units].
    lower, upper : float
        The funnel's bounds on it at that time [error units].
    """

    def __init__(self, index: int, value: float, lower: float, upper: float):
        super().__init__(f"component {index} = {value:.6g} outside ({lower:.6g}, {upper:.6g})")
        self.index, self.value, self.lower, self.upper = index, value, lower, upper


@dataclass(frozen=True)
class FunnelParams:
    """Parameters of one funnel, one entry per error component.

    rho0 > rhoinf > 0 [error units], beta > 0 [1/s], 0 < sigma <= 1.

    Parameters
    ----------
    rho0, rhoinf : tuple of float, shape (m,)
        rho(0) and rho(inf) of Eq. (18) [error units].
    beta : tuple of float, shape (m,)
        Decay rate of Eq. (18) [1/s].
    sigma : tuple of float, shape (m,)
        Ratio of the lower to the upper side, in (0, 1].
    """

    rho0: tuple[float, ...]
    rhoinf: tuple[float, ...]
    beta: tuple[float, ...]
    sigma: tuple[float, ...]

    def __post_init__(self) -> None:
        arrays = {}
        for name in ("rho0", "rhoinf", "beta", "sigma"):
            value = tuple(float(x) for x in np.atleast_1d(getattr(self, name)))
            object.__setattr__(self, name, value)
            arrays[name] = np.array(value)
        sizes = {name: len(a) for name, a in arrays.items()}
        if len(set(sizes.values())) != 1:
            raise ParameterError(f"funnel parameters have different lengths: {sizes}")
        if not np.all(np.isfinite(np.concatenate(list(arrays.values())))):
            raise ParameterError("funnel parameters must be finite")
        r0, ri, b, s = arrays["rho0"], arrays["rhoinf"], arrays["beta"], arrays["sigma"]
        if np.any(ri <= 0) or np.any(ri >= r0):
            raise ParameterError(
                f"funnel needs 0 < rhoinf < rho0, got rho0={self.rho0}, rhoinf={self.rhoinf}"
            )
        if np.any(b <= 0):
            raise ParameterError(f"funnel beta must be > 0, got {self.beta}")
        if np.any(s <= 0) or np.any(s > 1):
            raise ParameterError(f"funnel sigma must be in (0, 1], got {self.sigma}")

    @property
    def size(self) -> int:
        """Number of error components the funnel bounds."""
        return len(self.rho0)

    @cached_property
    def _decay_terms(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rho0 - rhoinf, rhoinf, beta) as arrays, computed once for :meth:`rho_and_rate`."""
        ri = np.array(self.rhoinf)
        return np.array(self.rho0) - ri, ri, np.array(self.beta)

    def rho_and_rate(self, t):
        """(rho(t), d rho/dt), Eqs. (18)-(19); ``t`` may be an array (broadcast against the
        components) or complex (complex step)."""
        span, ri, b = self._decay_terms
        decay = span * np.exp(-b * t)
        return decay + ri, -b * decay

    def rho(self, t) -> np.ndarray:
        """rho(t), Eq. (18)."""
        return self.rho_and_rate(t)[0]

    def rho_dot(self, t) -> np.ndarray:
        """d rho / dt, Eq. (19)."""
        return self.rho_and_rate(t)[1]


class FunnelEval(NamedTuple):
    """A funnel evaluated at one time (all element-wise arrays)."""

    error: np.ndarray  # e
    rho: np.ndarray  # rho(t)
    rho_dot: np.ndarray  # d rho / dt
    s: np.ndarray  # e / rho
    psi: np.ndarray  # transformed error, Eq. (20)
    Phi: np.ndarray  # diagonal of Phi, Eq. (22)
    margin: np.ndarray  # distance to the nearer bound, in units of rho (> 0 inside)


class Funnel:
    """A funnel with its sides fixed by the sign of the error at t = 0.

    ``Funnel(params, e0)``; ``evaluate(t, e)`` returns a :class:`FunnelEval` or raises
    :class:`FunnelExit`; ``inside(t, e)`` only checks.

    Parameters
    ----------
    params : FunnelParams
        rho0, rhoinf, beta, sigma of each component.
    initial_error : array_like, shape (m,)
        e(0); its signs fix which side of each funnel is the sigma side.
    """

    def __init__(self, params: FunnelParams, initial_error):
        e0 = np.asarray(initial_error, dtype=float)
        if e0.shape != (params.size,):
            raise ParameterError(
                f"funnel has {params.size} components, initial error has shape {e0.shape}"
            )
        self.params = params
        self.sigma = sg = np.array(params.sigma)
        self.positive_side = pos = e0 >= 0  # e(0) >= 0: upper bound 1, lower -sigma
        self.upper = np.where(pos, 1.0, sg)  # bounds on s
        self.lower = np.where(pos, -sg, -1.0)
        # Eq. (21) as R(s) = ln((a1 + b1 s) / (a2 + b2 s)), dR/ds = b1/num - b2/den:
        #   e(0) >= 0: ln((sigma + s) / (sigma - sigma s))
        #   e(0) <  0: ln((sigma + sigma s) / (sigma - s))
        self._a = sg
        self._b1 = np.where(pos, 1.0, sg)
        self._b2 = np.where(pos, -sg, -1.0)

    def kernel_table(self) -> np.ndarray:
        """(8, m) array of the constants a compiled kernel needs: rho_0, rho_inf, beta, and
        a, b1, b2 of Eq. (21) as ``R(s) = ln((a + b1 s) / (a + b2 s))``, the upper and lower
        bounds on s."""
        p = self.params
        rows = (p.rho0, p.rhoinf, p.beta, self._a, self._b1, self._b2, self.upper, self.lower)
        return np.ascontiguousarray(np.vstack(rows), dtype=float)

    def rho(self, t) -> np.ndarray:
        """rho(t), Eq. (18)."""
        return self.params.rho(t)

    def rho_dot(self, t) -> np.ndarray:
        """d rho / dt, Eq. (19)."""
        return self.params.rho_dot(t)

    def bounds(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) bounds on the error at time t."""
        r = self.rho(t)
        return self.lower * r, self.upper * r

    def margin(self, t: float, error) -> np.ndarray:
        """Distance of s = e / rho to the nearer bound (> 0 strictly inside).

        Parameters
        ----------
        t : float
            Time [s].
        error : array_like, shape (m,)
            e(t) [error units]; only its real part is used.

        Returns
        -------
        ndarray, shape (m,)
            Distance of s = e / rho to the nearer bound, > 0 inside.
        """
        s = np.real(np.asarray(error)) / self.rho(t)
        return np.minimum(self.upper - s, s - self.lower)

    def inside(self, t: float, error) -> bool:
        """True when every component of ``error`` is strictly inside the funnel at ``t``.

        Parameters
        ----------
        t : float
            Time [s].
        error : array_like, shape (m,)
            e(t) [error units].

        Returns
        -------
        bool
            True when every component is strictly inside.
        """
        return bool(np.all(self.margin(t, error) > 0))

    def evaluate(self, t, error) -> FunnelEval:
        """psi and Phi at (t, e). ``t`` and ``error`` may be complex (complex step).

        Parameters
        ----------
        t : float or complex
            Time [s].
        error : ndarray, shape (m,)
            e(t) [error units]; may be complex.

        Returns
        -------
        FunnelEval
            e, rho, d rho/dt, s, psi, Phi and the margin at t.
        """
        rho, rho_dot = self.params.rho_and_rate(t)
        s = error / rho
        sr = s.real
        margin = np.minimum(self.upper - sr, sr - self.lower)
        if margin.min() <= 0:
            i = int(np.argmin(margin))
            r = float(np.real(rho[i]))
            raise FunnelExit(i, float(np.real(error[i])), self.lower[i] * r, self.upper[i] * r)
        num = self._a + self._b1 * s
        den = self._a + self._b2 * s
        psi = np.log(num / den)  # Eq. (20)-(21)
        Phi = (self._b1 / num - self._b2 / den) / rho  # Eq. (22)
        return FunnelEval(error, rho, rho_dot, s, psi, Phi, margin)


class IdentityFunnel(Funnel):
    """Case 2 of the paper (no prescribed performance): psi = e, Phi = 1, rho_dot = 0.

    The funnel is still checked (``inside``/``margin``) for reporting, but ``evaluate``
    never refuses.
    """

    def evaluate(self, t, error) -> FunnelEval:
        """psi, Phi (Eqs. 18-24) of ``error`` at ``t`` without the funnel: psi = error,
        Phi = 1.

        Parameters
        ----------
        t : float or complex
            Time [s].
        error : ndarray, shape (m,)
            e(t) [error units].

        Returns
        -------
        FunnelEval
            psi = e, Phi = 1, rho = 1, d rho/dt = 0 and the margin.
        """
        one = np.ones(self.params.size)
        zero = np.zeros(self.params.size)
        margin = self.margin(np.real(t), np.real(error))
        return FunnelEval(error, one, zero, error, error, one, margin)
