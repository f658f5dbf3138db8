"""Kinematic level: the joint-rate command w_mc and its exact time derivative.

Coordinated law (Eqs. 25 and 36), written once for any m2, m3 (planar: m2 = 2, m3 = 1 with
``L_b = 1`` for the attitude angle; spatial: m2 = m3 = 3 with MRP attitudes and
``L_b = 1/4 B(q_b) R_0^T``, docs/spatial.md section 5)::

    a_b   = A0-hat + k_b H_bb-hat L_b^T Phi_b psi_b
    w_mc  = H_bm-hat^+ a_b + U-hat xi,              U-hat = I - H_bm-hat^+ H_bm-hat   # Eq. (25)
    xi    = (J_m-hat U-hat)^+ (-v0bar-hat + dz_ed/dt - k_z Phi_z psi_z - J_m-hat H_bm-hat^+ a_b)
                                                                                      # Eq. (36)

so that ``H_bm-hat w_mc = a_b`` (Eq. 26) and ``J_m-hat w_mc = -v0bar-hat + dz_ed/dt -
k_z Phi_z psi_z`` (Eq. 37). Beyond the paper, an optional null-space term
``(E - A^+ A) k_s grad mu`` (``A = J_m-hat U-hat``) is added to xi; it keeps both identities
(:mod:`.null_space`). Case 3 of the paper (no attitude regulation) uses Eq. (81)::

    w_mc = J_m-hat^+ (-v0bar-hat + dz_ed/dt - J_b-hat w_b - k_z Phi_z psi_z)

The task is the full pose z_e = (p_e, q_e) (m2 + m3 rows) or the position p_e only (m2 rows,
``task = "position"``); J_b, J_m, v0bar and the funnel z have that many rows.

``w_mc`` depends on (t, q, z_e, theta_b-hat, theta_z-hat) only (and on w_b for Eq. 81), so its
time derivative, needed by Eq. (64), is a directional derivative along known rates
(docs/model.md section 5). It is computed *exactly* by one complex-step evaluation
(``f(x + i h dx)``, ``df = Im / h``), which also returns the value as the real part: no
algebraic loop, no differencing of recorded values. Everything below is written with
analytic operations (plain transposes, explicit inverses) to keep that valid; the damping
of the pseudo-inverse is computed from the real part and held constant.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ..attitude import mrp
from ..errors import ParameterError
from ..model.interface import ReducedModel
from .funnel import Funnel, FunnelEval
from .gains import Gains
from .kernels import COMPLEX_STEP  # the step h of along_measured_motion (derivative = imag / h)
from .linalg import damped_row_pinv, row_pinv
from .null_space import NullSpace, null_space_gradient

_TWO_PI = 2.0 * np.pi


TASKS = ("pose", "position")


def wrap_angle(d):
    """Angle difference mapped to (-pi, pi] using the real part (complex-step safe)."""
    return d - _TWO_PI * np.round(np.real(d) / _TWO_PI)


def task_size(m2: int, m3: int, task: str) -> int:
    """Number of end-effector task components: m2 + m3 ("pose") or m2 ("position").

    Parameters
    ----------
    m2, m3 : int
        Position and attitude coordinates of the geometry.
    task : str
        "pose" or "position".

    Returns
    -------
    int
        m2 + m3 or m2.
    """
    if task not in TASKS:
        raise ParameterError(f"task {task!r} unknown; valid choices: {TASKS}")
    return m2 + m3 if task == "pose" else m2


def attitude_matrix(q_b, m3: int):
    """L_b of Eq. (1), dq_b/dt = L_b w_b (w_b inertial): 1 for a planar angle (m3 = 1),
    1/4 B(q_b) R_0^T for an MRP (m3 = 3, docs/spatial.md section 5). Complex-step safe.

    Parameters
    ----------
    q_b : float or ndarray
        Base attitude [rad] (planar) or MRP (spatial); may be complex.
    m3 : int
        Attitude coordinates: 1 planar, 3 spatial.
    """
    if m3 == 1:
        return np.ones((1, 1))
    return mrp.L_matrix(np.asarray(q_b))


def task_errors(reference, base_attitude_ref, t, q_b, z_e, m3: int = 1):
    """(err_b, err_z): attitude error q_b - q_bd (Eq. 16) and task error z_e - z_ed(t)
    (Eq. 17), one entry per reference component. Planar (m3 = 1): the
    angles are wrapped to (-pi, pi]; spatial: component differences of the MRPs (the paper's
    Delta q_b, Delta q_e), the measured MRPs being on the |s| <= 1 branch. Complex-step safe.

    Parameters
    ----------
    reference : Reference
        The task reference (``ee_pose(t)``, ``n_components``).
    base_attitude_ref : array_like
        Desired base attitude q_bd [rad] or MRP.
    t : float or complex
        Time [s].
    q_b : float or ndarray
        Base attitude [rad] or MRP.
    z_e : array_like
        End-effector pose; its first ``reference.n_components`` entries are used.
    m3 : int
        Attitude coordinates: 1 planar, 3 spatial.
    """
    n = reference.n_components
    return error_terms(np.atleast_1d(q_b), base_attitude_ref, np.array(z_e)[:n],
                       reference.ee_pose(t), m3)  # fmt: skip


def error_terms(q_b, base_attitude_ref, z_e, z_e_d, m3: int):
    """(err_b, err_z) = (q_b - q_bd, z_e - z_e,d) (Eqs. 16-17) of one sample or of rows
    (components along the last axis), wrapped as :func:`task_errors` says (planar angles to
    (-pi, pi]; MRPs as component differences).

    Parameters
    ----------
    q_b : ndarray
        Base attitude [rad] or MRP, components along the last axis.
    base_attitude_ref : array_like
        Desired base attitude q_bd.
    z_e, z_e_d : ndarray
        End-effector pose and its reference.
    m3 : int
        Attitude coordinates: 1 planar, 3 spatial.
    """
    err_b = q_b - np.asarray(base_attitude_ref)
    err_z = z_e - z_e_d
    if m3 == 1:
        err_b = wrap_angle(err_b)
        if err_z.shape[-1] > 2:
            err_z[..., 2] = wrap_angle(err_z[..., 2])
    return err_b, err_z


class ComplexStepMomentum:
    """``momentum_matrices`` of a model, with complex-step arguments evaluated through the
    model's real (compiled) ``mass_matrix`` and ``Y_Mdot`` instead of complex arithmetic.

    For ``theta_b = theta + i e theta'``, ``q = q + i e q'`` (e the complex step), to first
    order in e (exact in a complex step): ``H(theta_b, q) = H(theta, q) + i e (H(theta', q) +
    dH/dt)``, with dH/dt the rate of the first m3 rows of M(q, theta_d) along the motion
    ``dq_b/dt = q_b'``, ``dq_m/dt = q_m'``, i.e. ``w_b = L_b^-1 q_b'``, ``w_m = q_m'``. The
    rows of the symmetric dM/dt are the columns ``Y_Mdot(q, w, e_j) theta_d``. Used for the
    spatial model, whose complex (numpy) mass matrix costs about 0.5 ms.
    """

    def __init__(self, model: ReducedModel):
        self.model = model
        self.m3 = model.m3
        self._basis = np.eye(model.n_joints + model.m3)[: model.m3]

    def momentum_matrices(self, theta_b, q_b, q_m):
        """(H_bb, H_bm) of the estimated model, complex-step safe (Eq. 14).

        Parameters
        ----------
        theta_b : ndarray
            Estimated base parameters theta_b (Eq. 28); may be complex.
        q_b : ndarray, shape (3,)
            Base attitude (MRP); may be complex.
        q_m : ndarray, shape (n,)
            Joint angles [rad]; may be complex.
        """
        m, m3 = self.model, self.m3
        if not any(np.iscomplexobj(x) for x in (theta_b, q_b, q_m)):
            return m.momentum_matrices(theta_b, q_b, q_m)
        tb, qb, qm = (np.asarray(x) for x in (theta_b, q_b, q_m))
        tr, qbr, qmr = tb.real.copy(), qb.real.copy(), qm.real.copy()
        w = np.concatenate((np.linalg.solve(attitude_matrix(qbr, m3), qb.imag), qm.imag))
        scale = float(np.max(np.abs(w)))
        rows = m.mass_matrix(tr[m3:], qbr, qmr)[:m3]
        d_rows = m.mass_matrix(tb.imag[m3:], qbr, qmr)[:m3]  # linear in theta_d
        if scale > 0:  # dM/dt rows along the (rescaled) motion
            cols = [m.Y_Mdot(qbr, qmr, w / scale, e) @ tr[m3:] for e in self._basis]
            d_rows = d_rows + scale * np.array(cols)
        H = rows + 1j * d_rows
        return H[:, :m3], H[:, m3:], tb[:m3]


def momentum_evaluator(model: ReducedModel):
    """What evaluates H_bb, H_bm, A_0 of ``model`` at complex-step arguments: the model itself
    (planar), or :class:`ComplexStepMomentum` through its compiled real model (spatial)."""
    return ComplexStepMomentum(model) if model.m3 > 1 else model


def along_measured_motion(meas, m3: int) -> tuple[complex, Any, np.ndarray, np.ndarray]:
    """(t, q_b, q_m, z_e) + i h (1, dq_b/dt, w_m, dz_e/dt): a measurement advanced by a complex
    step along the measured rates (dq_b/dt = L_b w_b, Eq. 1), for exact time derivatives of a
    law evaluated at these arguments.

    Parameters
    ----------
    meas : Measurement
        The measurement (t, q_b, q_m, w, z_e).
    m3 : int
        Attitude coordinates: 1 planar, 3 spatial.

    Returns
    -------
    tuple
        (t, q_b, q_m, z_e), each advanced by i h along its rate.
    """
    w = meas.w
    q_b_rate = attitude_matrix(meas.q_b, m3) @ w[:m3]
    return (
        meas.t + 1j * COMPLEX_STEP,
        _complex(meas.q_b, q_b_rate[0] if m3 == 1 else q_b_rate),
        meas.q_m + 1j * COMPLEX_STEP * w[m3:],
        np.asarray(meas.z_e) + 1j * COMPLEX_STEP * meas.z_e_dot,
    )


class KinematicInputs(NamedTuple):
    """Arguments of w_mc (all may be complex for the complex step)."""

    t: float | complex  # [s]
    q_b: float | np.ndarray  # base attitude [rad] (planar) or MRP (spatial)
    q_m: np.ndarray  # joint angles [rad]
    z_e: np.ndarray  # measured end-effector pose [m, rad or MRP]
    theta_b: np.ndarray
    theta_z: np.ndarray
    w_b: float | np.ndarray  # base angular velocity, inertial [rad/s] (Eq. 81 only)


class KinematicCommand(NamedTuple):
    """w_mc, its time derivative and the diagnostics of one evaluation."""

    w_mc: np.ndarray  # [rad/s]
    w_mc_dot: np.ndarray  # [rad/s^2] (for Eq. 81: without the w_b contribution)
    dwmc_dwb: np.ndarray  # d w_mc / d w_b, (m1 x m3) (zero except for Eq. 81)
    funnel_b: FunnelEval | None
    funnel_z: FunnelEval
    sigma_min: float  # smallest singular value of J_m-hat U-hat (or J_m-hat)
    damping: float  # lambda^2 of the damped inverse, 0 when undamped
    H_bm_norm: float  # smallest singular value of H_bm-hat (its norm for m3 = 1), guards
    # against theta_b-hat collapsing


class KinematicLaw:
    """Eqs. (25)+(36) (``attitude=True``) or Eq. (81) (``attitude=False``).

    Parameters
    ----------
    model : ReducedModel
        The estimated model (its geometry and regressors).
    gains : Gains
        k_b and k_z are used.
    funnel_b, funnel_z : Funnel
        Funnels of the attitude and task errors (Eqs. 16-17).
    reference : Reference
        The task reference (``ee_pose(t)``, ``n_components``).
    base_attitude_ref : float or ndarray
        Desired base attitude q_bd [rad] (planar) or MRP (spatial).
    threshold : float
        Damped least squares below this smallest singular value [m].
    attitude : bool
        Eqs. (25)+(36) when True, Eq. (81) when False.
    null_space : NullSpace or None
        The secondary task; None: none.
    null_space_center : array_like or None
        The joint-centering center [rad].
    task : str
        "pose" (m2 + m3 task rows) or "position" (m2).
    """

    def __init__(
        self,
        model: ReducedModel,
        gains: Gains,
        funnel_b: Funnel,
        funnel_z: Funnel,
        reference,
        base_attitude_ref: float | np.ndarray,
        threshold: float,
        attitude: bool = True,
        null_space: NullSpace | None = None,
        null_space_center=None,
        task: str = "pose",
    ):
        self.model = model
        self.m2, self.m3 = model.m2, model.m3
        # spatial: H_bb, H_bm through the compiled real model (see ComplexStepMomentum)
        self._momentum = momentum_evaluator(model)
        self.task = task
        self.n_task = task_size(self.m2, self.m3, task)
        self.k_b, self.k_z = gains.k_b, gains.k_z
        self.funnel_b, self.funnel_z = funnel_b, funnel_z
        self.reference = reference
        self.q_bd = np.atleast_1d(np.asarray(base_attitude_ref, dtype=float))
        self.threshold = threshold
        self.attitude = attitude
        self.n = model.n_joints
        self.null_space = NullSpace() if null_space is None else null_space
        if self.null_space.active and not attitude:
            raise ParameterError(
                "null_space: the null-space term is defined for Eq. (36) (schemes 'ppc', "
                "'no-ppc', 'known-model'), not for the scheme 'no-attitude' (Eq. 81)"
            )
        self.center = (
            None if null_space_center is None else self.null_space.center_for(null_space_center)
        )
        if self.null_space.objective == "joint-centering" and self.center is None:
            raise ParameterError("null_space: joint-centering needs the initial joint angles")

    def errors(self, t, q_b, z_e):
        """(err_b, err_z), see :func:`task_errors`.

        Parameters
        ----------
        t : float or complex
            Time [s].
        q_b : float or ndarray
            Base attitude [rad] or MRP.
        z_e : ndarray
            End-effector pose.
        """
        return task_errors(self.reference, self.q_bd, t, q_b, z_e, self.m3)

    def evaluate(self, x: KinematicInputs):
        """w_mc at x; returns (w_mc, funnel_b, funnel_z, sigma_min, damping, |H_bm|, J_pinv_Jb)."""
        m = self.model
        err_b, err_z = self.errors(x.t, x.q_b, np.array(x.z_e))
        fz = self.funnel_z.evaluate(x.t, err_z)
        nt, m3 = self.n_task, self.m3
        J_b, J_m = m.jacobians(x.theta_z, x.q_b, x.q_m)
        J_b, J_m = J_b[:nt], J_m[:nt]
        v0bar = np.zeros(nt, dtype=J_m.dtype)
        v0bar[: self.m2] = x.theta_z[: self.m2]
        target = -v0bar + self.reference.ee_rate(x.t) - self.k_z * fz.Phi * fz.psi
        if not self.attitude:  # Eq. (81)
            inv = damped_row_pinv(J_m, self.threshold)
            if m3 == 1:  # planar: the scalar w_b, as the compiled kernel writes it
                w_mc = inv.pinv @ (target - J_b[:, 0] * x.w_b)
                sens = -(inv.pinv @ J_b[:, 0])[:, None]
            else:
                w_mc = inv.pinv @ (target - J_b @ x.w_b)
                sens = -(inv.pinv @ J_b)
            return w_mc, None, fz, inv.sigma_min, inv.damping, np.nan, sens
        fb = self.funnel_b.evaluate(x.t, err_b)
        H_bb, H_bm, A0 = self._momentum.momentum_matrices(x.theta_b, x.q_b, x.q_m)
        if m3 == 1:  # planar: L_b = 1
            a_b = A0 + self.k_b * H_bb[0, 0] * fb.Phi * fb.psi  # (1,), Eq. (25)
        else:
            L_b = attitude_matrix(x.q_b, m3)
            a_b = A0 + self.k_b * (H_bb @ (L_b.T @ (fb.Phi * fb.psi)))  # (m3,), Eq. (25)
        Hp = row_pinv(H_bm)  # (n, m3)
        U = np.eye(self.n) - Hp @ H_bm
        A = J_m @ U
        inv = damped_row_pinv(A, self.threshold)
        Hp_ab = Hp @ a_b
        xi = inv.pinv @ (target - J_m @ Hp_ab)  # Eq. (36)
        if self.null_space.active:  # beyond the paper: xi_n = (E - A^+ A) k_s grad mu
            assert self.center is not None  # set in __init__ when the option is active
            grad = null_space_gradient(
                self.null_space, self.center, x.q_m, lambda q: self._reduced_jacobian(x, q)
            )
            xi = xi + self.null_space.gain * (grad - inv.pinv @ (A @ grad))
        w_mc = Hp_ab + U @ xi  # Eq. (25)
        HH = np.real(H_bm @ H_bm.T)
        if m3 == 1:
            h_norm = float(np.sqrt(HH[0, 0]))
        else:  # smallest singular value of H_bm-hat
            h_norm = float(np.sqrt(max(np.linalg.eigvalsh(HH)[0], 0.0)))
        return w_mc, fb, fz, inv.sigma_min, inv.damping, h_norm, np.zeros((self.n, m3))

    def _reduced_jacobian(self, x: KinematicInputs, q_m):
        """A = J_m-hat U-hat of Eq. (36) at joint angles q_m (complex-step safe)."""
        _, J_m = self.model.jacobians(x.theta_z, x.q_b, q_m)
        J_m = J_m[: self.n_task]
        _, H_bm, _ = self._momentum.momentum_matrices(x.theta_b, x.q_b, q_m)
        U = np.eye(self.n) - row_pinv(H_bm) @ H_bm
        return J_m @ U

    def command(self, x: KinematicInputs, rates: KinematicInputs) -> KinematicCommand:
        """w_mc at x and d w_mc / dt along ``rates`` (dt/dt = 1, dq/dt, dz_e/dt, ...).

        ``rates.w_b`` is ignored: for Eq. (81) the contribution of dw_b/dt is returned as the
        sensitivity ``dwmc_dwb`` and added by the caller, who knows dw_b/dt.

        Parameters
        ----------
        x : KinematicInputs
            Where w_mc is evaluated.
        rates : KinematicInputs
            Rates of the arguments along which d w_mc / dt is taken.

        Returns
        -------
        KinematicCommand
            w_mc [rad/s], its derivative [rad/s^2] and the diagnostics.
        """
        xc = KinematicInputs(
            x.t + 1j * COMPLEX_STEP * rates.t,
            _complex(x.q_b, rates.q_b),
            np.asarray(x.q_m) + 1j * COMPLEX_STEP * np.asarray(rates.q_m),
            np.asarray(x.z_e) + 1j * COMPLEX_STEP * np.asarray(rates.z_e),
            np.asarray(x.theta_b) + 1j * COMPLEX_STEP * np.asarray(rates.theta_b),
            np.asarray(x.theta_z) + 1j * COMPLEX_STEP * np.asarray(rates.theta_z),
            _complex(x.w_b, 0.0),
        )
        w_mc, fb, fz, sigma, damping, h_norm, sens = self.evaluate(xc)
        return KinematicCommand(
            w_mc=w_mc.real.copy(),
            w_mc_dot=w_mc.imag / COMPLEX_STEP,
            dwmc_dwb=np.real(sens[:, 0] if self.m3 == 1 else sens),
            funnel_b=None if fb is None else _real_eval(fb),
            funnel_z=_real_eval(fz),
            sigma_min=sigma,
            damping=damping,
            H_bm_norm=h_norm,
        )


def _complex(value, rate):
    """value + i h rate; a scalar stays a scalar (planar attitude), arrays stay arrays."""
    if np.ndim(value) == 0:
        return value + 1j * COMPLEX_STEP * rate
    return np.asarray(value) + 1j * COMPLEX_STEP * np.asarray(rate)


def _real_eval(f: FunnelEval) -> FunnelEval:
    return FunnelEval(*(np.real(np.asarray(a)) for a in f))
