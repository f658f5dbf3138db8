"""Controller gains and the singularity policy, as frozen validated dataclasses."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError


def _positive(obj, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ParameterError(
                f"{type(obj).__name__}.{name} must be a positive finite number, got {value!r}"
            )


@dataclass(frozen=True)
class Gains:
    """Gains of the coordinated controller (the paper's Section 4 values by default).

    Parameters
    ----------
    k_b : float
        Attitude gain of Eq. (25) [1/s].
    k_z : float
        End-effector gain of Eq. (36) [1/s].
    k_de : float
        Filter rate of Eqs. (46), (50) [1/s].
    k_d : float
        Sliding rate of Eq. (64) [1/s].
    gamma_1, gamma_2, gamma_3 : float
        Adaptation gains of Eqs. (28), (42), (51).
    """

    k_b: float = 0.04
    k_z: float = 0.04
    k_de: float = 0.3
    k_d: float = 0.8
    gamma_1: float = 10.0
    gamma_2: float = 10.0
    gamma_3: float = 10.0

    def __post_init__(self) -> None:
        _positive(self, *(f.name for f in fields(self)))


@dataclass(frozen=True)
class SingularityPolicy:
    """What the kinematic law does near a singular ``J_m-hat U-hat`` (Eq. 36).

    Parameters
    ----------
    threshold : float
        sigma_min below which damped least squares starts [same units as J, m]. The damping
        is ``lambda^2 = threshold^2 - sigma_min^2``, so the damped inverse never amplifies by
        more than ``1 / threshold`` and is continuous where damping starts.
    max_damped_time : float
        The run stops (cause ``"singular"``) when sigma_min stays below ``threshold`` for
        longer than this [s]. Damping keeps the law defined, so brief passages (the paper's
        case 2 passes a fold of the *estimated* arm for about 6 s before theta_z-hat adapts)
        are ridden out and reported; an arm held at a fold (e.g. a reference out of reach)
        is stopped.
    """

    threshold: float = 0.05
    max_damped_time: float = 10.0

    def __post_init__(self) -> None:
        _positive(self, "threshold", "max_damped_time")


# --------------------------------------------------------------------------- derived gains
#: Square of the rate of an attitude coordinate per unit angular rate near zero attitude, by
#: the number m3 of attitude components: a planar angle moves at the angular rate (1); an
#: MRP at a quarter of it, and the base attitude law of Eq. (25) meets that factor twice,
#: through L_b^T in the command and L_b in the motion (L_b L_b^T ~ E_3 / 16; docs/gains.md).
ATTITUDE_RATE_SQUARED = {1: 1.0, 3: 1.0 / 16.0}

#: Largest explicit-step product g dt a derived gain may reach at the end of its funnel (the
#: stability limit is 2; a quarter of it leaves room for the transformation's steepening).
STEP_MARGIN = 0.5


def loop_rate(k: float, funnel, rho, scale: float = 1.0) -> np.ndarray:
    """Rate g [1/s] at which the kinematic law of Eqs. (25) / (36) closes an error component
    near e = 0 when the funnel width is ``rho``: g = k scale (dR/ds)^2 / rho^2, with
    dR/ds = 1 + 1/sigma the slope of the transformation (21) at s = 0, so that
    d e / dt = -k scale Phi psi ~ -g e (Eq. 22). ``funnel`` is a
    :class:`~ffsm_pin.control.funnel.FunnelParams`.

    Parameters
    ----------
    k : float
        The kinematic gain [1/s].
    funnel : FunnelParams
        Its sigma is used.
    rho : array_like
        Funnel width [error units].
    scale : float
        Factor of the rate (the attitude law's, :data:`ATTITUDE_RATE_SQUARED`).

    Returns
    -------
    ndarray
        g [1/s], per component.
    """
    slope = 1.0 + 1.0 / np.asarray(funnel.sigma, dtype=float)
    return k * scale * slope**2 / np.asarray(rho, dtype=float) ** 2


def derived_gain(funnel, dt: float, scale: float = 1.0) -> float:
    """The kinematic gain (k_b or k_z) a scenario gets when it omits it [1/s units of Eq. 25].

    The smallest gain whose loop rate at t = 0 matches the funnel's own decay on every
    component, g(rho_0) >= beta (a slower law lets the funnel close in on the error and
    relies on the transformation's steepening near its boundary), capped so that at the end
    of the funnel the explicit step stays well inside its stability limit,
    g(rho_inf) dt <= :data:`STEP_MARGIN`. On the paper's planar funnels (rho_0 = 1,
    beta = 0.22, sigma = 0.8) the rule gives 0.0435 for both gains, the paper's 0.04 to
    within 9 %; on the shipped spatial funnels it gives the hand-derived gains of
    ``spatial.toml`` to within 30 % (docs/gains.md).

    Parameters
    ----------
    funnel : FunnelParams
        The funnel of the errors the gain acts on.
    dt : float
        The control period [s].
    scale : float
        Factor of the loop rate (:func:`loop_rate`).

    Returns
    -------
    float
        The gain [1/s].
    """
    rho0, rhoinf = np.asarray(funnel.rho0), np.asarray(funnel.rhoinf)
    unit = loop_rate(1.0, funnel, rho0, scale)  # g(rho_0) per unit k
    k_start = float(np.max(np.asarray(funnel.beta) / unit))
    k_step = float(np.min(STEP_MARGIN / (dt * loop_rate(1.0, funnel, rhoinf, scale))))
    return min(k_start, k_step)


class GainWarning(UserWarning):
    """Gains that violate a discrete-time condition at the scenario's dt (the run goes on;
    ``--check`` refuses it)."""


class GainProblem(NamedTuple):
    """A discrete-time condition a gain violates: ``text`` names the gain, the product that
    breaks the condition and a value that satisfies it."""

    gain: str
    value: float
    suggested: float
    text: str


def step_problems(gains: Gains, funnel_b, funnel_z, dt: float, m3: int,
                  attitude: bool = True) -> list[GainProblem]:  # fmt: skip
    """The explicit-step conditions of the coordinated controller that ``gains`` violate at
    the control period ``dt`` [s] (docs/gains.md): the kinematic laws g(rho_inf) dt < 2 for
    k_z and (with the attitude law) k_b, and the sliding rate k_d dt < 2 of Eq. (64). The
    adaptation laws and the filter are integrated exactly or implicitly (no condition).

    Parameters
    ----------
    gains : Gains
        The gains checked.
    funnel_b, funnel_z : FunnelParams
        The attitude and end-effector funnels.
    dt : float
        The control period [s].
    m3 : int
        Attitude coordinates: 1 planar, 3 spatial.
    attitude : bool
        The attitude law is on (k_b checked).

    Returns
    -------
    list of GainProblem
        The violated conditions, empty when none.
    """
    out = []
    rows = [("k_z", gains.k_z, funnel_z, 1.0)]
    if attitude:
        rows.append(("k_b", gains.k_b, funnel_b, ATTITUDE_RATE_SQUARED[m3]))
    for name, k, funnel, scale in rows:
        g_dt = loop_rate(k, funnel, funnel.rhoinf, scale) * dt
        if np.max(g_dt) >= 2.0:
            i = int(np.argmax(g_dt))
            good = derived_gain(funnel, dt, scale)
            out.append(GainProblem(name, k, good, (
                f"controller.{name} = {k:g} is too large for dt = {dt:g} s: at the end of its "
                f"funnel (rho_inf[{i}] = {funnel.rhoinf[i]:g}) the kinematic law closes the error "
                f"at g = {g_dt[i] / dt:.4g} 1/s, g dt = {g_dt[i]:.3g} >= 2 (an explicit step "
                f"diverges); {name} = {good:.3g} satisfies it (the value derived when {name} "
                "is omitted; docs/gains.md)"
            )))  # fmt: skip
    if gains.k_d * dt >= 2.0:
        good = STEP_MARGIN / dt
        out.append(GainProblem("k_d", gains.k_d, good, (
            f"controller.k_d = {gains.k_d:g} is too large for dt = {dt:g} s: k_d dt = "
            f"{gains.k_d * dt:.3g} >= 2 (Eq. 64's explicit step diverges); k_d <= {good:.3g} "
            "satisfies it"
        )))  # fmt: skip
    return out
