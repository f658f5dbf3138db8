"""Pseudo-inverses that are analytic (complex-step safe), with documented damping."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class DampedInverse(NamedTuple):
    """A right pseudo-inverse and how it was obtained."""

    pinv: np.ndarray  # A^T (A A^T + lambda^2 I)^-1
    sigma_min: float  # smallest singular value of A (real part)
    damping: float  # lambda^2 (0 when undamped)


def row_pinv(a: np.ndarray) -> np.ndarray:
    """Pseudo-inverse of a full-row-rank matrix, ``A^T (A A^T)^-1``; uses the plain
    transpose (not the conjugate) so that it stays analytic for complex-step derivatives."""
    return a.T @ np.linalg.inv(a @ a.T)


def damped_row_pinv(a: np.ndarray, threshold: float) -> DampedInverse:
    """Right pseudo-inverse with damped least squares near rank loss.

    ``sigma_min`` is the smallest singular value of ``Re(A)``. Below ``threshold`` the
    damping ``lambda^2 = threshold^2 - sigma_min^2`` is added, so that the smallest
    eigenvalue of ``A A^T + lambda^2 I`` is ``threshold^2``: the gain of the inverse is
    bounded by ``1 / threshold`` and it is continuous where damping starts. The damping is
    computed from the real part and held constant in a complex-step derivative.

    Parameters
    ----------
    a : ndarray, shape (m, k)
        A wide matrix, real or complex.
    threshold : float
        Damping starts below this sigma_min [units of a].

    Returns
    -------
    DampedInverse
        The inverse, sigma_min and the damping lambda^2.
    """
    gram = a @ a.T
    eig = np.linalg.eigvalsh(gram.real)
    sigma_min = float(np.sqrt(max(eig[0], 0.0)))
    damping = 0.0
    if sigma_min < threshold:
        damping = threshold**2 - sigma_min**2
        gram = gram + damping * np.eye(gram.shape[0])
    return DampedInverse(a.T @ np.linalg.inv(gram), sigma_min, damping)
