"""Saturation-aware prescribed performance: the auxiliary (anti-windup) system of
``controller.saturation = "auxiliary"`` (beyond the paper; docs/saturation.md).

The paper's law (Sections 3.1-3.3) does not know that its joint torques saturate. With the
option on, the law computes the torque its actuators apply, ``u_a = clip(u_c, -L, L)`` (L the
scenario's ``[actuators] torque_limit``, handed over as plain numbers by
:attr:`~.interface.ControllerContext.torque_limit`), and the excess ``du = u_a - u_c`` drives an
auxiliary system (x = chi)::

    dw      = M-hat^-1 (0, du)                       velocity lost per second (base and joints)
    chi_v'  = -k_v chi_v + dw                        the velocity deficit, (m3 + n)
    chi_b'  = -k_chi chi_b + L_b chi_v[:m3]          the attitude deficit, Eq. (1), (m3)
    chi_z'  = -k_chi chi_z + J-hat chi_v             the task deficit, Eq. (3), (n_task)

over a period by the exact hold of the excess (zero-order hold; chi_v at t drives chi_b,
chi_z). The law then works on the relaxed errors ``e_b - chi_b``, ``e_z - chi_z`` (the
transformation of Eq. 21 on them, with their exact rates), its dynamic level tracks
``w_mc + chi_v[m3:]`` with the rate ``dw_mc/dt - k_v chi_v[m3:]``, and its filter (Eq. 46)
integrates ``dw`` besides, as the torque applied is ``u_a``: the velocity lost to the excess is
in w-hat and in the target alike, so the dynamic level does not ask for it back while the
actuators saturate (its decay, k_v chi_v, it does). Every chi is exactly zero while nothing
saturates (it starts at zero and only an excess moves it), so such a run is the paper's law
bit for bit; after the saturation ends, chi decays at k_v and k_chi and the prescribed funnel
returns.

The numpy reference is here (:class:`AuxiliarySystem`); the compiled one is
:mod:`.saturation_kernels`, run by :func:`.period.period`; both are tested against each other.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError, choices_text

#: ``controller.saturation``: the paper's law (``"ignore"``) or the auxiliary system.
SATURATION_MODES = ("ignore", "auxiliary")


@dataclass(frozen=True)
class Saturation:
    """``controller.saturation`` and its auxiliary system's rates.

    Attributes
    ----------
    mode : str
        One of :data:`SATURATION_MODES`.
    k_chi : float or None
        Decay rate of the attitude and task deficits chi_b, chi_z [1/s]; None: the slowest
        funnel's beta (the prescribed funnel returns at the funnel's own pace).
    k_v : float or None
        Decay rate of the velocity deficit chi_v [1/s]; None: the law's k_d (the rate at
        which its dynamic level removes a velocity error, Eq. 64).
    """

    mode: str = "ignore"
    k_chi: float | None = None
    k_v: float | None = None

    def __post_init__(self) -> None:
        if self.mode not in SATURATION_MODES:
            raise ParameterError(
                f"controller.saturation = {self.mode!r}: valid choices: "
                f"{choices_text(SATURATION_MODES)}"
            )
        for key in ("k_chi", "k_v"):
            value = getattr(self, key)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise ParameterError(f"controller.{key} = {value!r}: must be > 0")

    def rates(self, funnel_b, funnel_z, k_d: float) -> tuple[float, float]:
        """(k_chi, k_v) [1/s], the omitted ones derived (see the attributes).

        Parameters
        ----------
        funnel_b, funnel_z : FunnelParams
            The run's funnels.
        k_d : float
            The law's sliding gain [1/s].

        Returns
        -------
        tuple of float
            k_chi and k_v.
        """
        k_chi = self.k_chi
        if k_chi is None:
            k_chi = float(min(min(funnel_b.beta), min(funnel_z.beta)))
        return float(k_chi), float(self.k_v if self.k_v is not None else k_d)


class AuxiliaryTerm(NamedTuple):
    """The auxiliary system's constants as a period reads them (:func:`auxiliary_term`)."""

    limit: np.ndarray  # (n,) [N m], inf where none
    decay_v: float  # exp(-k_v dt)
    gain_v: float  # (1 - exp(-k_v dt)) / k_v
    rate_v: float  # k_v
    decay_chi: float  # exp(-k_chi dt)
    gain_chi: float  # (1 - exp(-k_chi dt)) / k_chi
    rate_chi: float  # k_chi


def auxiliary_term(saturation: Saturation, limit, rates, dt: float) -> AuxiliaryTerm | None:
    """The :class:`AuxiliaryTerm` of a run, or None when ``saturation.mode`` is ``"ignore"``.

    Parameters
    ----------
    saturation : Saturation
        The option.
    limit : array_like or None
        Per-joint torque limit [N m] (inf where none); None: no limits.
    rates : tuple of float
        (k_chi, k_v) [1/s] (:meth:`Saturation.rates`).
    dt : float
        The control period [s].

    Returns
    -------
    AuxiliaryTerm or None
        The constants; None for the paper's law.
    """
    if saturation.mode == "ignore":
        return None
    k_chi, k_v = rates
    lim = np.array(limit, dtype=float).reshape(-1)
    return AuxiliaryTerm(lim, float(np.exp(-k_v * dt)), float(-np.expm1(-k_v * dt) / k_v),
                         k_v, float(np.exp(-k_chi * dt)), float(-np.expm1(-k_chi * dt) / k_chi),
                         k_chi)  # fmt: skip


def state_size(nb: int, m3: int, n_task: int) -> int:
    """Entries of the auxiliary state: chi_v (nb), chi_b, chi_z.

    Parameters
    ----------
    nb : int
        m3 + n.
    m3 : int
        Attitude coordinates (1 planar, 3 spatial).
    n_task : int
        Task rows.

    Returns
    -------
    int
        nb + m3 + n_task.
    """
    return nb + m3 + n_task


class AuxiliarySystem:
    """The readable numpy reference of the auxiliary system (module docstring).

    Parameters
    ----------
    term : AuxiliaryTerm
        Its constants.
    nb, m3, n_task : int
        Sizes: base and joint velocities, attitude coordinates, task rows.

    Attributes
    ----------
    state : ndarray
        (chi_v, chi_b, chi_z), as the compiled period keeps it.
    """

    def __init__(self, term: AuxiliaryTerm, nb: int, m3: int, n_task: int):
        self.term, self.nb, self.m3 = term, nb, m3
        self.state = np.zeros(state_size(nb, m3, n_task))

    def parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(chi_v, chi_b, chi_z), views of :attr:`state`."""
        nb, m3, s = self.nb, self.m3, self.state
        return s[:nb], s[nb : nb + m3], s[nb + m3 :]

    def rates(self, J: np.ndarray, L_b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(-k_v chi_v, chi_b', chi_z') at t, the task Jacobian ``J`` (n_task, nb) and attitude
        matrix ``L_b`` (m3, m3) at t: the rates the law feeds forward (chi_v's without the
        excess, which the filter's w-hat takes; module docstring).

        Parameters
        ----------
        J : ndarray
            J-hat of Eq. (3), the task's rows, over (w_b, w_m).
        L_b : ndarray
            L_b of Eq. (1).

        Returns
        -------
        tuple of ndarray
            The three rates.
        """
        chi_v, chi_b, chi_z = self.parts()
        k_v, k_chi = self.term.rate_v, self.term.rate_chi
        return (
            -k_v * chi_v,
            -k_chi * chi_b + L_b @ chi_v[: self.m3],
            -k_chi * chi_z + J @ chi_v,
        )

    def command(self, u_c: np.ndarray, a: np.ndarray, M: np.ndarray, S) -> np.ndarray:
        """:func:`feasible_command` with this system's limits.

        Parameters
        ----------
        u_c, a, M, S
            As :func:`feasible_command`.

        Returns
        -------
        ndarray, shape (n,)
            The command [N m].
        """
        return feasible_command(self.term.limit, u_c, a, M, S)

    def advance(self, u_c: np.ndarray, u_f: np.ndarray, M: np.ndarray, J: np.ndarray,
                L_b: np.ndarray):  # fmt: skip
        """The excess du = clip(u_f) - u_c [N m] and the state at t + dt, in place; returns
        dw = M^-1 (0, du) [rad/s^2] (zeros when nothing saturates).

        Parameters
        ----------
        u_c : ndarray, shape (n,)
            The law's command (before :meth:`command`).
        u_f : ndarray, shape (n,)
            The command of :meth:`command`.
        M : ndarray
            M-hat at t (the true M for the known-model scheme).
        J, L_b : ndarray
            As :meth:`rates`, at t.

        Returns
        -------
        ndarray, shape (nb,)
            dw.
        """
        t = self.term
        du = np.clip(u_f, -t.limit, t.limit) - u_c
        chi_v, chi_b, chi_z = self.parts()
        new_dw = np.zeros(self.nb)
        if np.any(du != 0.0):
            rhs = np.zeros(self.nb)
            rhs[self.m3 :] = du
            new_dw = np.linalg.solve(M, rhs)
        drive_b = L_b @ chi_v[: self.m3]
        drive_z = J @ chi_v
        chi_b[:] = t.decay_chi * chi_b + t.gain_chi * drive_b
        chi_z[:] = t.decay_chi * chi_z + t.gain_chi * drive_z
        chi_v[:] = t.decay_v * chi_v + t.gain_v * new_dw
        return new_dw


def feedforward_gain(M: np.ndarray, S: np.ndarray) -> np.ndarray:
    """G = du_m / da, the joint torque per unit of the dynamic level's feedforward a (the rate
    of its target w_mc + chi_v, Eqs. 60a, 64-65 with the base rows eliminated).

    ``G = M_mm - (M_mb + M_mm S) (M_bb + M_bm S)^-1 M_bm``; with S = d w_mc / d w_b = 0
    (every scheme but Eq. 81) the Schur complement M* of the base block, for which
    ``M^-1 (0, G a) = (-M_bb^-1 M_bm a, a)``.

    Parameters
    ----------
    M : ndarray, shape (m3 + n, m3 + n)
        M-hat.
    S : ndarray, shape (n, m3)
        d w_mc / d w_b.

    Returns
    -------
    ndarray, shape (n, n)
        G.
    """
    m3 = M.shape[0] - S.shape[0]
    Mbb, Mbm, Mmb, Mmm = M[:m3, :m3], M[:m3, m3:], M[m3:, :m3], M[m3:, m3:]
    return Mmm - (Mmb + Mmm @ S) @ np.linalg.solve(Mbb + Mbm @ S, Mbm)


def feasible_scale(u0: np.ndarray, g: np.ndarray, limit: np.ndarray) -> float:
    """The largest s in [0, 1] with |u0_j + s g_j| <= max(L_j, |u0_j|) for every joint j.

    ``u0`` is the command without the feedforward, ``g = G a`` the feedforward's torque:
    scaling a by s keeps its direction, never pushes a joint beyond its limit (nor beyond
    |u0_j| where u0 alone exceeds it). s = 0 is always feasible.

    Parameters
    ----------
    u0, g : ndarray, shape (n,)
        [N m].
    limit : ndarray, shape (n,)
        L [N m], inf where none.

    Returns
    -------
    float
        s.
    """
    s = 1.0
    for j in range(u0.size):
        if g[j] != 0.0:
            bound = max(limit[j], abs(u0[j]))
            s = min(s, max(0.0, (np.copysign(bound, g[j]) - u0[j]) / g[j]))
    return s


def feasible_command(limit, u_c, a, M, S) -> np.ndarray:
    """The law's command with its feedforward scaled to what the actuators deliver: ``u_c``
    itself when every joint is within its limit (bit for bit), else ``u0 + s G a`` with
    ``u0 = u_c - G a`` and s of :func:`feasible_scale` (docs/saturation.md, "The feasible
    rate"). The torque removed, ``-(1 - s) G a``, is an excess like the clip's: the
    auxiliary system books it as velocity not delivered (:meth:`AuxiliarySystem.advance`).

    Parameters
    ----------
    limit : ndarray, shape (n,)
        L [N m], inf where none.
    u_c : ndarray, shape (n,)
        The law's command [N m].
    a : ndarray, shape (n,)
        Its feedforward, the rate of the tracked w_mc + chi_v [rad/s^2].
    M : ndarray
        M-hat.
    S : ndarray, shape (n, m3)
        d w_mc / d w_b.

    Returns
    -------
    ndarray, shape (n,)
        The command [N m].
    """
    if np.all(np.abs(u_c) <= limit):
        return u_c
    g = feedforward_gain(M, np.reshape(S, (u_c.size, -1))) @ a
    u0 = u_c - g
    return u0 + feasible_scale(u0, g, limit) * g


class SaturationWarning(UserWarning):
    """``--check``: the law's command at t = 0 exceeds the actuators' torque limit
    (:func:`demand_problem`)."""


def demand_problem(u_c, limit, mode: str) -> str | None:
    """The feasibility estimate of ``--check`` (docs/saturation.md): the law's first command
    ``u_c`` against the torque ``limit``; a message when some joint needs more than its limit.

    The first command is what the funnels ask of the actuators at t = 0: the kinematic law's
    rate ``k Phi psi`` grows with the funnel's speed (k derived from beta, docs/gains.md) and
    the dynamic level reaches it at k_d, through M-hat. A ratio above 1 means the prescribed
    convergence needs more torque than the limits give at the start (a necessary condition
    for the paper's law to run unsaturated; not sufficient later in the run).

    Parameters
    ----------
    u_c : array_like, shape (n,)
        The law's command at t = 0 [N m].
    limit : array_like, shape (n,)
        The torque limits [N m], inf where none.
    mode : str
        ``controller.saturation`` (named in the advice).

    Returns
    -------
    str or None
        The warning's text, or None when every joint is within its limit.
    """
    ratio = np.abs(np.asarray(u_c, dtype=float)) / np.asarray(limit, dtype=float)
    j = int(np.argmax(ratio))
    if not ratio[j] > 1.0:
        return None
    advice = (
        "the auxiliary system relaxes the funnels while the actuators saturate"
        if mode == "auxiliary"
        else "set controller.saturation = 'auxiliary', or slow the funnel (beta, rho_0)"
    )
    return (
        f"torque demand at t = 0: joint {j} is commanded {abs(float(np.ravel(u_c)[j])):.4g} N m, "
        f"{ratio[j]:.3g} x its actuators.torque_limit: the funnels ask for more torque than "
        f"the actuators give; {advice}"
    )


__all__ = [
    "SATURATION_MODES", "AuxiliarySystem", "AuxiliaryTerm", "Saturation", "SaturationWarning",
    "auxiliary_term", "demand_problem", "feasible_command", "feasible_scale", "feedforward_gain",
    "state_size",
]  # fmt: skip
