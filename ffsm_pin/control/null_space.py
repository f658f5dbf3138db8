"""Beyond the paper: use the spare joints of J_m-hat U-hat (option ``[controller.null_space]``).

When m_1 > (m_2 + m_3) + m_3, ``A = J_m-hat U-hat`` (Eq. 36) has a null space, and the paper's
minimum-norm ``xi`` leaves it unused. The option adds to ``xi`` of Eq. (36)::

    xi_n = (E - A^+ A) k_s grad_{q_m} mu

with ``A^+`` the same (possibly damped) right pseudo-inverse as in Eq. (36). Where that
inverse is undamped, ``A A^+ = E``, so ``A xi_n = 0`` and ``J_m-hat w_mc`` is unchanged
(Eq. 37); ``H_bm-hat U-hat = 0`` keeps Eq. (26). The paper's stability argument, which only
uses Eqs. (26) and (37), still holds.

Objectives ``mu`` (maximised):

* ``"manipulability"``: ``mu = sqrt(det(A A^T))`` [m^2] of the *estimated* A; its gradient with
  respect to q_m is a central difference of real perturbations of q_m (step
  :data:`GRADIENT_STEP`), evaluated inside the complex-step evaluation of w_mc, so dw_mc/dt
  stays the exact derivative of the commanded w_mc;
* ``"joint-centering"``: ``mu = -1/2 |q_m - center|^2`` [rad^2], gradient ``center - q_m``;
  ``center`` defaults to the initial joint angles of the run;
* ``"none"`` (default): the paper's Eq. (36), nothing added.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, choices_text

OBJECTIVES = ("none", "manipulability", "joint-centering")
# codes of the compiled kernel (ffsm_pin.control.fast): index in OBJECTIVES
OBJECTIVE_CODE = {name: i for i, name in enumerate(OBJECTIVES)}
# [rad] real step of the central difference of mu (truncation ~ step^2 * mu''' / 6,
# rounding ~ 1e-16 * mu / step: both ~1e-10 relative for link lengths of order 1 m)
GRADIENT_STEP = 1e-5


@dataclass(frozen=True)
class NullSpace:
    """Null-space term added to Eq. (36).

    Parameters
    ----------
    objective : str
        One of :data:`OBJECTIVES`.
    gain : float
        k_s >= 0 [rad^2/(m^2 s)] for "manipulability", [1/s] for "joint-centering".
    center : tuple of float or None
        Joint angles q_m of the joint-centering potential [rad]; None = the initial joint
        angles of the run (ignored by the other objectives).
    """

    objective: str = "none"
    gain: float = 1.0
    center: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if self.objective not in OBJECTIVES:
            raise ParameterError(
                f"null_space.objective {self.objective!r} unknown; valid choices: "
                f"{choices_text(OBJECTIVES)}"
            )
        g = self.gain
        if not (isinstance(g, (int, float)) and math.isfinite(g) and g >= 0):
            raise ParameterError(f"null_space.gain must be a finite number >= 0, got {g!r}")
        if self.center is not None:
            c = tuple(float(x) for x in self.center)
            if not all(math.isfinite(x) for x in c):
                raise ParameterError(f"null_space.center must be finite, got {list(c)}")
            object.__setattr__(self, "center", c)

    @property
    def active(self) -> bool:
        """True when the term is added (an objective other than "none")."""
        return self.objective != "none"

    def center_for(self, q_m0) -> np.ndarray:
        """The joint-centering centre for a run starting at q_m0 [rad] (read-only)."""
        q_m0 = np.asarray(q_m0, dtype=float)
        c = q_m0.copy() if self.center is None else np.array(self.center, dtype=float)
        if c.shape != q_m0.shape:
            raise ParameterError(
                f"null_space.center has {c.size} values, the robot has {q_m0.size} joints"
            )
        c.flags.writeable = False
        return c


def spd_det(G):
    """Determinant of a symmetric positive definite matrix by elimination without pivoting.

    Complex-step safe, unlike ``np.linalg.det``, which goes through ``slogdet`` and takes the
    modulus of the pivots (not analytic). No pivoting is needed for SPD matrices.
    """
    G = np.array(G)
    det = 1.0
    for k in range(G.shape[0]):
        det = det * G[k, k]
        G[k + 1 :, k + 1 :] -= np.outer(G[k + 1 :, k] / G[k, k], G[k, k + 1 :])
    return det


def manipulability(A):
    """mu = sqrt(det(A A^T)) with the plain transpose (complex-step safe) [m^2 planar]."""
    return np.sqrt(spd_det(A @ A.T))


def null_space_gradient(ns: NullSpace, center: np.ndarray, q_m, reduced_jacobian):
    """grad_{q_m} mu at q_m (may be complex); ``reduced_jacobian(q_m)`` returns A = J_m U.

    Parameters
    ----------
    ns : NullSpace
        The term (its objective).
    center : ndarray, shape (n,)
        Joint-centering center [rad].
    q_m : ndarray, shape (n,)
        Joint angles [rad]; may be complex.
    reduced_jacobian : callable
        q_m -> A = J_m U.
    """
    if ns.objective == "joint-centering":
        return center - q_m
    n = len(q_m)
    grad = np.zeros(n, dtype=np.result_type(q_m, float))
    for j in range(n):
        step = np.zeros(n)
        step[j] = GRADIENT_STEP
        mu_p = manipulability(reduced_jacobian(q_m + step))
        mu_m = manipulability(reduced_jacobian(q_m - step))
        grad[j] = (mu_p - mu_m) / (2.0 * GRADIENT_STEP)
    return grad
