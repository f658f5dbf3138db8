"""End-effector references from data: samples (C2 cubic spline) and waypoints (rest-to-rest
quintics), as one piecewise polynomial (docs/cli.md, "References from data").

The interpolants are SciPy's (:class:`scipy.interpolate.CubicSpline`, not-a-knot ends, and
:meth:`scipy.interpolate.BPoly.from_derivatives` with zero velocity and acceleration at every
waypoint); this module stores them in one layout that a numpy evaluation
(:meth:`PiecewisePolynomial.derivative`, complex-step safe) and the compiled controller
periods (``reference_kernels``) read alike. Before the first time the first value is
held, after the last time the last value (the velocity and acceleration are zero there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._docstrings import fill_doc
from ..errors import ParameterError, choices_text
from ._docs import SCENARIO_DOC

#: How samples become a reference: "spline" (C2 cubic through every sample, ``ee_file`` /
#: ``ee_samples``) or "waypoints" (rest-to-rest quintic between consecutive waypoints).
INTERPOLATIONS = ("spline", "waypoints")
DEGREE = 5  # quintic: the highest degree either interpolation needs


@dataclass(frozen=True)
class ReferenceData:
    """Samples of the end-effector task reference z_e,d.

    Attributes
    ----------
    times : tuple of float
        Increasing sample times [s], at least 2.
    values : tuple of tuple of float
        One row per time, one entry per task component (positions [m], attitude [rad]
        planar or MRP spatial).
    interpolation : str
        ``"spline"`` or ``"waypoints"`` (:data:`INTERPOLATIONS`).
    file : str or None
        The CSV the samples came from (for messages; the samples are what is used).
    """

    times: tuple[float, ...]
    values: tuple[tuple[float, ...], ...]
    interpolation: str = "spline"
    file: str | None = None

    def __post_init__(self) -> None:
        key = "ee_waypoints" if self.interpolation == "waypoints" else "ee_samples"
        what = self.file or f"reference.{key}"
        if self.interpolation not in INTERPOLATIONS:
            raise ParameterError(
                f"interpolation {self.interpolation!r} unknown; valid choices: "
                f"{choices_text(INTERPOLATIONS)}"
            )
        t = np.asarray(self.times, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise ParameterError(f"{what}: at least 2 samples are needed, got {t.size}")
        widths = {len(row) for row in self.values}
        if len(self.values) != t.size or len(widths) != 1:
            raise ParameterError(
                f"{what}: every sample needs one value per task component "
                f"({len(self.values)} rows for {t.size} times, widths {sorted(widths)})"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(np.asarray(self.values)))):
            raise ParameterError(f"{what}: times and values must be finite numbers")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            i = int(bad[0])
            raise ParameterError(
                f"{what}: times must increase; sample {i + 1} (t = {t[i + 1]:g} s) does not "
                f"come after sample {i} (t = {t[i]:g} s)"
            )

    @property
    def n_components(self) -> int:
        """Task components per sample."""
        return len(self.values[0])

    def with_values(self, values: np.ndarray) -> ReferenceData:
        """The same times and interpolation with other values (no file: they are new)."""
        rows = tuple(tuple(float(x) for x in row) for row in np.asarray(values, dtype=float))
        return ReferenceData(self.times, rows, self.interpolation, None)

    def polynomial(self) -> PiecewisePolynomial:
        """The interpolant of the samples."""
        # imported here: SciPy's interpolate takes a quarter of a second to import, and
        # only a reference from data needs it
        from scipy.interpolate import BPoly, CubicSpline, PPoly

        t = np.asarray(self.times, dtype=float)
        z = np.asarray(self.values, dtype=float)
        if self.interpolation == "spline":
            pp: PPoly = CubicSpline(t, z, axis=0, bc_type="not-a-knot")
            coefs = pp.c  # (4, segments, components), highest power first
        else:  # rest-to-rest: value, zero velocity and acceleration at every waypoint
            cols = []
            for k in range(z.shape[1]):
                ends = [[z[i, k], 0.0, 0.0] for i in range(t.size)]
                cols.append(PPoly.from_bernstein_basis(BPoly.from_derivatives(t, ends)).c)
            coefs = np.stack(cols, axis=-1)  # (6, segments, components)
        return PiecewisePolynomial.from_scipy(t, coefs)


@dataclass(frozen=True, eq=False)
class PiecewisePolynomial:
    """A vector polynomial per segment, held constant outside [times[0], times[-1]].

    ``table`` (shape ``(1 + (DEGREE + 1) * n, segments)``) is what the compiled kernels read:
    row 0 the segment start times [s], then for each power p = 0..DEGREE the n coefficients of
    (t - start)^p. Segment 0 holds the first value (it is used before the first sample), the
    last segment holds the last value from the last sample time on.
    """

    table: np.ndarray

    @classmethod
    def from_scipy(cls, breaks: np.ndarray, coefs: np.ndarray) -> PiecewisePolynomial:
        """From SciPy's PPoly layout: ``coefs[k, i, j]`` multiplies (t - breaks[i])^(deg - k).

        Parameters
        ----------
        breaks : ndarray
            The segments' start times [s] and the end.
        coefs : ndarray, shape (deg + 1, segments, n)
            SciPy's PPoly coefficients.

        Returns
        -------
        PiecewisePolynomial
            The polynomial.
        """
        deg = coefs.shape[0] - 1
        nseg, n = coefs.shape[1], coefs.shape[2]
        table = np.zeros((1 + (DEGREE + 1) * n, nseg + 2))
        table[0, 0] = breaks[0]  # hold the first value (chosen when t < breaks[0])
        table[0, 1:-1] = breaks[:-1]
        table[0, -1] = breaks[-1]
        for p in range(deg + 1):
            table[1 + p * n : 1 + (p + 1) * n, 1:-1] = coefs[deg - p].T
        first = coefs[deg, 0]  # the value at breaks[0]
        h = breaks[-1] - breaks[-2]
        last = sum(coefs[deg - p, -1] * h**p for p in range(deg + 1))  # value at breaks[-1]
        table[1 : 1 + n, 0] = first
        table[1 : 1 + n, -1] = last
        return cls(np.ascontiguousarray(table))

    @classmethod
    def empty(cls, n: int) -> PiecewisePolynomial:
        """No segments: contributes nothing (a reference given by harmonics only)."""
        return cls(np.zeros((1 + (DEGREE + 1) * n, 0)))

    @property
    def n_components(self) -> int:
        """Components of the value."""
        return (self.table.shape[0] - 1) // (DEGREE + 1)

    @fill_doc(SCENARIO_DOC)
    def derivative(self, t: Any, order: int = 0) -> np.ndarray:
        """d^order value / dt^order at the scalar time ``t`` [s] (complex t for complex steps:
        the segment is chosen by Re t). Shape ``(n,)``.

        Parameters
        ----------
        %(t_order)s

        Returns
        -------
        ndarray, shape (n,)
            The derivative.
        """
        n = self.n_components
        starts = self.table[0]
        k = max(int(np.searchsorted(starts, np.real(t), side="right")) - 1, 0)
        tau = t - starts[k]
        return self._horner(k, tau, order, np.zeros(n, dtype=np.result_type(tau, float)))

    def sample(self, ts: np.ndarray, order: int = 0) -> np.ndarray:
        """d^order value / dt^order at the real times ``ts`` [s], shape ``(len(ts), n)``.

        Parameters
        ----------
        ts : ndarray
            Real times [s].
        order : int
            Order of the derivative (0: the value).

        Returns
        -------
        ndarray, shape (len(ts), n)
            The derivative at each time.
        """
        ts = np.asarray(ts, dtype=float)
        n = self.n_components
        starts = self.table[0]
        k = np.maximum(np.searchsorted(starts, ts, side="right") - 1, 0)
        return self._horner(k, (ts - starts[k])[:, None], order, np.zeros((ts.size, n)))

    def _horner(self, k, tau, order: int, out: np.ndarray) -> np.ndarray:
        """Horner's scheme for the order-th derivative on the segments ``k`` (an index, or an
        array of them with ``tau`` a column), accumulated onto ``out`` (zeros)."""
        n = self.n_components
        for p in range(DEGREE, order - 1, -1):
            fac = float(math.perm(p, order))  # p! / (p - order)!: the factor of tau^(p - order)
            out = out * tau + fac * self.table[1 + p * n : 1 + (p + 1) * n, k].T
        return out


__all__ = ["DEGREE", "INTERPOLATIONS", "PiecewisePolynomial", "ReferenceData"]
