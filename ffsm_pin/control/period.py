"""The paper's control period, compiled once for both geometries.

One period (Eqs. 28, 42, 25+36 or 81, 46, 49-52, 60-64; docs/model.md) is the same
sequence of steps for a planar robot (m3 = 1) and a spatial one (m3 = 3): the geometry's terms
at the measured state and the estimators' steps (Eqs. 28, 42), the kinematic law evaluated
once with complex arguments ``x + i h dx/dt`` (its real part ``w_mc``, its imaginary part over
h the exact ``dw_mc/dt``), the dynamic level (Eqs. 46, 49-52, 60-64), the updates of the
estimators and the outputs. :func:`period` writes that sequence once. What differs is how each
step is computed from the robot's geometry: a planar robot's body angles and closed-form
products, a spatial robot's rotations, MRP attitudes and 3x3 solves. Those three steps
(:func:`geometry_terms`, :func:`kinematic_law`, :func:`dynamic_level`) are the geometry's
compiled kernels (:mod:`.fast` for :class:`~ffsm_pin.model.planar.PlanarKernelConstants`,
:mod:`.fast_spatial` for :class:`~ffsm_pin.model.spatial.SpatialKernelConstants`), chosen by
numba when it compiles :func:`period` from the type of the model's constants (the table
:data:`GEOMETRIES`), so the choice costs nothing per period and each geometry's arithmetic is
exactly its own.

What a period needs travels as named bundles (NamedTuples numba types by their class):

* ``geo``: the model's kernel constants;
* :class:`PeriodLaw`: the scheme's flags, gains (:class:`KernelGains`), singularity threshold,
  desired base attitude, funnels, null-space option (:mod:`.kernels`), the true theta_d of
  the diagnostic e, the projection of ``adaptation = "physical"`` (:mod:`.physical`);
* :class:`~.reference_kernels.ReferenceArrays`: the end-effector reference;
* the measurement (:class:`~.interface.Measurement`, with the true M and C w of a known-model
  run, read-only stand-ins otherwise);
* :class:`PeriodState`: the estimates, w-hat and the filtered regressor, advanced in place;
* :class:`PeriodOutputs`: preallocated outputs, the signals as views of one row of the
  controller's ``signal_layout`` (:func:`period_outputs`).

The readable reference is the numpy controller (:class:`~.controller.CoordinatedController`
with ``backend = "numpy"``); ``tests/control/test_fast.py`` and ``test_fast_spatial.py`` check
the two against each other, planar and spatial.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit

from .._array_kernels import put
from .._docstrings import fill_doc
from ..model.planar import PlanarKernelConstants
from ..model.spatial import SpatialKernelConstants
from . import _first_compile, fast, fast_spatial
from ._dispatch import JIT_OPTIONS, overload_for_geometry
from ._docs import CONTROL_DOC
from ._period_box import PeriodBox, period_box
from .interface import Measurement, SignalLayout
from .kernels import (
    COMPLEX_STEP,
    STATUS_FUNNEL_B,
    STATUS_FUNNEL_Z,
    STATUS_OK,
    NullSpaceTerm,
    funnel_constants,
    null_space_term,
)
from .physical import PhysicalTerm
from .reference_kernels import ReferenceArrays
from .saturation_kernels import auxiliary_advance, auxiliary_maps, feasible_command, relaxed

#: The compiled kernels of each geometry, by the type of the model's kernel constants. Each
#: module provides the period's three steps (``geometry_terms``, ``kinematic_law``,
#: ``dynamic_level``, with the signatures of the stubs below; the last also gives the
#: diagnostic e of Eq. 54), the true-model reaction torque ``reaction_rows``
#: (:mod:`.diagnostics`), and small functions the first compilation and the diagnostics
#: use: ``base_velocity(w)``, ``true_model_constants(geo)``, ``reaction_rows_of(q_b, q_m, w,
#: dw_b)`` and ``compile_beside_law(meas, state)`` (a first run's, before the law).
GEOMETRIES: dict[type, Any] = {
    PlanarKernelConstants: fast,
    SpatialKernelConstants: fast_spatial,
}


# ---------------------------------------------------------------------- the bundles
class KernelGains(NamedTuple):
    """The paper's gains (:class:`~.gains.Gains`) as the compiled period reads them."""

    k_b: float
    k_z: float
    k_de: float
    k_d: float
    gamma_1: float
    gamma_2: float
    gamma_3: float


class PeriodLaw(NamedTuple):
    """The constants of a run of the paper's law (made once, :func:`period_law`)."""

    n_task: int  # task rows (pose: m2 + m3, position: m2)
    attitude: bool  # the base attitude is regulated (False: Eq. 81, scheme no-attitude)
    identity: bool  # psi = e, Phi = 1 (scheme no-ppc)
    adaptive: bool  # False: the known-model scheme (the true M and C w, no adaptation)
    gains: KernelGains
    threshold: float  # [m] damped least squares below this sigma_min
    q_bd: np.ndarray  # desired base attitude (m3,) [rad or MRP]
    funnel_b: np.ndarray  # records of kernels.FUNNEL_RECORD, one per component
    funnel_z: np.ndarray
    null_space: NullSpaceTerm | None  # None: the paper's Eq. (36), nothing compiled for it
    theta_d_true: np.ndarray  # the true theta_d for the diagnostic e (empty: not computed)
    physical: PhysicalTerm | None  # the projection of Eq. (51)'s step; None: the paper's law


class PeriodState(NamedTuple):
    """What a period advances to t + dt, in place (Table 2 gives the start)."""

    theta_z: np.ndarray  # Eq. (42)
    theta_d: np.ndarray  # Eq. (51)
    theta_b: np.ndarray  # Eq. (28)
    w_hat: np.ndarray  # the filter's state, Eq. (46)
    Y_df: np.ndarray  # the filtered regressor, Eq. (50)


class PeriodOutputs(NamedTuple):
    """Where a period writes its outputs (preallocated, reused every period). The signals
    are views of one row of the controller's ``signal_layout`` (:func:`period_outputs`);
    ``sigma_min`` and ``damping`` one-entry views."""

    u_m: np.ndarray  # joint torques (n,) [N m]
    w_mc_dot: np.ndarray  # dw_mc/dt with the base's acceleration fed back (n,)
    err_b: np.ndarray  # attitude error (m3,)
    err_z: np.ndarray  # task error (n_task,)
    w_tilde: np.ndarray
    e: np.ndarray  # Eq. (54), written when the law has theta_d_true
    theta_z_hat: np.ndarray  # the estimates and w-hat at t, before the period advances them
    theta_d_hat: np.ndarray
    theta_b_hat: np.ndarray
    w_hat: np.ndarray
    w_mc: np.ndarray
    sigma_min: np.ndarray
    damping: np.ndarray


#: The signals a period writes (the fields of :class:`PeriodOutputs` that are views of the
#: signals' row).
SIGNALS = ("w_tilde", "e", "theta_z_hat", "theta_d_hat", "theta_b_hat", "w_hat", "w_mc",
           "sigma_min", "damping")  # fmt: skip


def period_law(*, n_task: int, scheme: str, gains, threshold: float, q_bd, funnel_b, funnel_z,
               null_space, center, n_joints: int, theta_d_true,
               physical: PhysicalTerm | None = None) -> PeriodLaw:  # fmt: skip
    """The :class:`PeriodLaw` of a controller: its scheme, :class:`~.gains.Gains`, the
    singularity threshold [m], desired base attitude, its two
    :class:`~.funnel.Funnel` (sides fixed), :class:`~.null_space.NullSpace` with the
    joint-centering ``center``, and the true theta_d (None: e is not computed).

    Parameters
    ----------
    n_task : int
        Task rows (pose: m2 + m3, position: m2).
    scheme : str
        One of :data:`~.schemes.SCHEMES`.
    gains : Gains
        The controller's gains.
    threshold : float
        Singularity threshold [m].
    q_bd : array_like
        Desired base attitude [rad] or MRP.
    funnel_b, funnel_z : Funnel
        The attitude and task funnels, sides fixed.
    null_space : NullSpace or None
        The secondary task.
    center : array_like or None
        Its joint-centering center [rad].
    n_joints : int
        Number of joints n.
    theta_d_true : array_like or None
        The true theta_d (None: e is not computed).
    physical : PhysicalTerm or None
        The projection of ``adaptation = "physical"`` (None: the paper's Eq. 51).

    Returns
    -------
    PeriodLaw
        The constants of the run.
    """
    return PeriodLaw(
        int(n_task), scheme != "no-attitude", scheme == "no-ppc", scheme != "known-model",
        KernelGains(*(float(getattr(gains, k)) for k in KernelGains._fields)), float(threshold),
        np.array(q_bd, dtype=float).reshape(-1), funnel_constants(funnel_b),
        funnel_constants(funnel_z), null_space_term(null_space, center, n_joints),
        np.empty(0) if theta_d_true is None else np.array(theta_d_true, dtype=float), physical,
    )  # fmt: skip


def law_fields(law: PeriodLaw) -> tuple:
    """The fields of ``law`` as :func:`period` takes them: a plain tuple, the gains' too (the
    null-space term stays a named tuple or None: numba prunes its code on None)."""
    return (*law[:4], tuple(law.gains), *law[5:])


def period_outputs(
    layout: SignalLayout, n: int, m3: int, n_task: int
) -> tuple[PeriodOutputs, np.ndarray]:
    """(outputs, row): the :class:`PeriodOutputs` of ``n`` joints, m3 attitude coordinates and
    n_task task rows, its signals views of ``row``, one row of ``layout`` (which must have
    exactly the signals of :data:`SIGNALS`, any order).

    Parameters
    ----------
    layout : SignalLayout
        The controller's signal layout (the signals of :data:`SIGNALS`).
    n : int
        Number of joints.
    m3 : int
        Attitude coordinates.
    n_task : int
        Task rows.

    Returns
    -------
    outputs : PeriodOutputs
        The outputs, its signals views of ``row``.
    row : ndarray
        One row of ``layout``.
    """
    if set(layout.shapes) != set(SIGNALS):
        raise ValueError(f"period_outputs: the layout's signals must be {SIGNALS}")
    row = np.zeros(layout.size)
    views = {key: row[start:stop] for key, (start, stop, _) in layout.slots.items()}
    return PeriodOutputs(np.zeros(n), np.zeros(n), np.zeros(m3), np.zeros(n_task), **views), row


# ---------------------------------------------------------------------- the geometry's steps
@fill_doc(CONTROL_DOC)
def geometry_terms(geo, law, dt, meas, state):
    """The geometry's terms at the measured state, and Eqs. (28), (42) over the period.

    Returns ``(terms, theta_b(t + dt), theta_z(t + dt), dq_b/dt, w_b)``: ``terms`` what the
    dynamic level reuses (geometry-specific), the estimates after the period (unchanged when
    ``law.adaptive`` is False), the attitude's rate (Eq. 1) and the base's angular velocity.
    Compiled per geometry (:data:`GEOMETRIES`); this Python body is never run.

    %(params_geometry_terms)s
    """
    raise NotImplementedError


@fill_doc(CONTROL_DOC)
def kinematic_law(geo, law, ref, ns, t, q_b, q_m, z_e, theta_b, theta_z, w_b):
    """w_mc of Eqs. (25)+(36) or (81) at complex arguments: (w_mc, d w_mc / d w_b, sigma_min,
    damping, |H_bm|, err_b, err_z, status, exit index). ``ns`` is ``law.null_space``, an
    argument of its own so that numba prunes the null-space term when it is None. Compiled per
    geometry.

    %(params_kinematic_law)s
    """
    raise NotImplementedError


@fill_doc(CONTROL_DOC)
def dynamic_level(geo, terms, law, dt, meas, w_mc, w_mc_dot, sens, state):
    """Eqs. (46), (49)-(52), (60)-(64): (status, exit value, u_m, w_mc_dot fed with the
    base's acceleration, w~, e); advances theta_d-hat, w-hat and Y_df of ``state`` in place
    when the status is ``STATUS_OK``. ``e`` the diagnostic e of Eq. (54) with the true M and
    ``law.theta_d_true`` (empty when that is). Compiled per geometry.

    %(params_dynamic_level)s
    """
    raise NotImplementedError


def _register(cls: type, kernels: Any) -> None:
    """Have numba compile each step of :func:`period` as ``kernels``' function of the same name
    when the model's constants are a ``cls``.

    The implementation is the kernel's own Python function compiled with the kernel's cache
    (``cache=True``: the same file and name, so the same cache entries), not a wrapper
    calling it: a first run finds the kernels the second process compiled
    (:func:`compile_in_parallel`), and compiles no extra layer (each layer costs numba a
    pass of LLVM over all the code below it, about 2 s of a first run for the three steps).
    """
    for stub in (geometry_terms, kinematic_law, dynamic_level):
        overload_for_geometry(stub, cls, getattr(kernels, stub.__name__).py_func)


_JIT_OPTIONS = JIT_OPTIONS  # (the steps' jit options: tests read them here)


for _cls, _kernels in GEOMETRIES.items():
    _register(_cls, _kernels)


# ---------------------------------------------------------------------- one period
def period(geo, law_f, ref_f, dt, meas_f, state_f, out_f, aux):
    """One control period at the measurement (time t [s]) over [t, t + dt): advances the
    state in place, writes the outputs and returns (status, exit index, value).

    :func:`period_of` with the fixed arguments put in a box first (for tests and benchmarks
    that call one period; a controller keeps its box and calls :func:`period_of`).

    ``geo`` the model's kernel constants (a named tuple: its type selects the geometry's
    kernels); the other bundles arrive as the plain tuples of their fields, in order
    (:func:`law_fields` for :class:`PeriodLaw`; ``tuple(...)`` of
    :class:`~.reference_kernels.ReferenceArrays`, :class:`~.interface.Measurement`,
    :class:`PeriodState`, :class:`PeriodOutputs`) and are named again here: numba types a
    plain tuple from Python at a fraction of a named one's cost (each named tuple's class and
    field names are part of its type), and this is called every period. The known-model
    scheme (``law.adaptive`` False) reads Pinocchio's reduced M and C w from ``meas.M``,
    ``meas.h``. ``value`` is what a stop reports: the exiting error component (a funnel exit,
    its index the exit index), |H_bm-hat| (its collapse), the smallest singular value of the
    base rows' matrix (a singular filter); |H_bm-hat| otherwise.

    Parameters
    ----------
    geo : PlanarKernelConstants or SpatialKernelConstants
        The model's kernel constants (its type selects the geometry).
    law_f : tuple
        The fields of a :class:`PeriodLaw` (:func:`law_fields`).
    ref_f : tuple
        The fields of a :class:`~.reference_kernels.ReferenceArrays`.
    dt : float
        The period [s].
    meas_f : tuple
        The fields of a :class:`~.interface.Measurement`.
    state_f : tuple
        The fields of a :class:`PeriodState`, advanced in place.
    out_f : tuple
        The fields of a :class:`PeriodOutputs`, written.
    aux : tuple or None
        ``(AuxiliaryTerm, state)``, the auxiliary system of ``controller.saturation =
        "auxiliary"`` (:mod:`.saturation_kernels`; its state advanced in place), or None: the
        paper's law (numba compiles none of it).

    Returns
    -------
    tuple
        (status, exit index, value).
    """
    return period_of(period_box(geo, law_f, ref_f, state_f, out_f), dt, meas_f, aux)


@njit(cache=True)
def period_of(box, dt, meas_f, aux):
    """:func:`period` with its fixed arguments in one :class:`~._period_box.PeriodBox`: numba
    unboxes one reference per call instead of the bundles' 50-odd arrays. ``aux`` stays an
    argument of its own: numba prunes the auxiliary system's code when an argument is None,
    not when a field is.

    Parameters
    ----------
    box : PeriodBox
        ``geo``, ``law_f``, ``ref_f``, ``state_f`` and ``out_f`` of :func:`period`
        (:func:`~._period_box.period_box`).
    dt : float
        The period [s].
    meas_f : tuple
        The fields of a :class:`~.interface.Measurement`.
    aux : tuple or None
        As in :func:`period`.

    Returns
    -------
    tuple
        (status, exit index, value), as :func:`period`.
    """
    geo, law_f, ref_f, state_f, out_f = box.geo, box.law, box.ref, box.state, box.out
    g = law_f[4]
    law = PeriodLaw(law_f[0], law_f[1], law_f[2], law_f[3], KernelGains(*g), law_f[5], law_f[6],
                    law_f[7], law_f[8], law_f[9], law_f[10], law_f[11])  # fmt: skip
    ref, meas = ReferenceArrays(*ref_f), Measurement(*meas_f)
    state, out = PeriodState(*state_f), PeriodOutputs(*out_f)
    n = meas.q_m.size
    w = meas.w
    # the estimates and w-hat at t, written now, before they advance
    put(out.theta_z_hat, 0, state.theta_z)
    put(out.theta_d_hat, 0, state.theta_d)
    put(out.theta_b_hat, 0, state.theta_b)
    put(out.w_hat, 0, state.w_hat)
    terms, tb_new, tz_new, q_b_rate, w_b = geometry_terms(geo, law, dt, meas, state)  # (28), (42)

    # kinematic level, value and exact derivative in one complex evaluation
    hj = 1j * COMPLEX_STEP
    theta_b, theta_z = state.theta_b, state.theta_z
    q_c, q_m_c = meas.q_b + hj * q_b_rate, meas.q_m + hj * w[w.size - n :]
    tb_c, tz_c = theta_b + hj * (tb_new - theta_b) / dt, theta_z + hj * (tz_new - theta_z) / dt
    if aux is None:
        w_mc_c, sens, sigma, damping, hnorm, err_b, err_z, status, idx = kinematic_law(
            geo, law, ref, law.null_space, meas.t + hj, q_c, q_m_c,
            meas.z_e + hj * meas.z_e_dot, tb_c, tz_c, w_b + 0j,
        )  # fmt: skip
    else:  # the relaxed errors e_b - chi_b, e_z - chi_z (saturation.py)
        M_a, J_a, L_a = auxiliary_maps(geo, law, meas, state)
        q_bd_r, z_c, chi_v, chi_v_dot = relaxed(
            aux[0], aux[1], J_a, L_a, law.q_bd, meas.z_e, meas.z_e_dot, hj
        )
        law_r = PeriodLaw(law[0], law[1], law[2], law[3], law[4], law[5], q_bd_r, law[7],
                          law[8], law[9], law[10], law[11])  # fmt: skip
        w_mc_c, sens, sigma, damping, hnorm, err_b, err_z, status, idx = kinematic_law(
            geo, law_r, ref, law.null_space, meas.t + hj, q_c, q_m_c, z_c, tb_c, tz_c, w_b + 0j
        )
    for i in range(err_b.size):
        out.err_b[i] = err_b[i].real
    for i in range(err_z.size):
        out.err_z[i] = err_z[i].real
    out.sigma_min[0] = sigma
    out.damping[0] = damping
    if status != STATUS_OK:
        value = hnorm
        if status == STATUS_FUNNEL_Z or status == STATUS_FUNNEL_B:
            value = (err_z[idx] if status == STATUS_FUNNEL_Z else err_b[idx]).real
        return status, idx, value
    w_mc = w_mc_c.real.copy()
    w_mc_dot = w_mc_c.imag / COMPLEX_STEP

    w_dyn, w_dyn_dot = w_mc, w_mc_dot
    if aux is not None:  # the dynamic level tracks w_mc + chi_v (the deficit let go)
        m3 = w.size - n
        w_dyn, w_dyn_dot = w_mc + chi_v[m3:], w_mc_dot + chi_v_dot[m3:]
    status, value, u_m, w_mc_dot_fed, w_tilde, e_54 = dynamic_level(
        geo, terms, law, dt, meas, w_dyn, w_dyn_dot, np.ascontiguousarray(sens), state
    )
    if status != STATUS_OK:
        return status, -1, value  # (a singular filter: the smallest singular value)
    if aux is not None:  # the feasible feedforward; the excess drives chi; the filter
        u_f = feasible_command(aux[0], u_m, w_dyn_dot, M_a, sens)  # integrates what acts
        dw = auxiliary_advance(aux[0], aux[1], u_m, u_f, M_a, J_a, L_a)
        u_m = u_f
        if np.any(dw != 0.0):
            put(state.w_hat, 0, state.w_hat + dt * dw)
    if law.adaptive:
        put(theta_b, 0, tb_new)
        put(theta_z, 0, tz_new)
    put(out.u_m, 0, u_m)
    put(out.w_mc_dot, 0, w_mc_dot_fed)
    put(out.w_tilde, 0, w_tilde)
    put(out.e, 0, e_54)  # (nothing when not computed)
    put(out.w_mc, 0, w_mc)
    return STATUS_OK, -1, hnorm


# ---------------------------------------------------------------------- first compilation
def compile_in_parallel(geo, law, ref, meas, state) -> None:
    """On a first run, compile the geometry's real kernels (those :func:`period` calls, then
    the run's reaction torques) in a second process while this one compiles the geometry's
    complex kinematic law (:mod:`._first_compile`); :func:`period` then loads the former from
    the cache. The arguments are those of :func:`period` (the measurement with the types a
    run passes). Does nothing when the cache is warm.

    Parameters
    ----------
    geo, law, ref, meas, state : NamedTuple
        The arguments of :func:`period`, as named tuples.
    """
    kernels = GEOMETRIES[type(geo)]
    _first_compile.compile_in_parallel(
        __name__,
        (geo, law, ref, meas, state),
        (kernels.kinematic_law,),
        lambda: _compile_here(kernels, geo, law, ref, meas, state),
    )


def _compile_here(kernels, geo, law, ref, meas, state) -> None:
    """A first run's compiling here: ``compile_beside_law``, then ``kinematic_law`` with the
    types :func:`period` passes (complex values of the measurement's shapes)."""
    kernels.compile_beside_law(meas, state)
    c, w_b = 1j * COMPLEX_STEP, kernels.base_velocity(meas.w) + 0j
    kernels.kinematic_law(geo, law, ref, law.null_space, meas.t + c, meas.q_b + c, meas.q_m + c,
                          meas.z_e + c, state.theta_b + c, state.theta_z + c, w_b)  # fmt: skip


def _compile_real_kernels(geo, law, ref, meas, state) -> None:
    """Compile the geometry's real steps of :func:`period` with the argument types it passes
    (the second process of :func:`compile_in_parallel`, on its own copies: the state moves)."""
    kernels = GEOMETRIES[type(geo)]
    n = meas.q_m.size
    terms, _, _, _, w_b = kernels.geometry_terms(geo, law, 1e-3, meas, state)
    sens = np.zeros((n, *np.shape(w_b)))  # d w_mc / d w_b: (n,) planar, (n, 3) spatial
    kernels.dynamic_level(geo, terms, law, 1e-3, meas, np.zeros(n), np.zeros(n), sens, state)


def _compile_run_kernels(geo, law, ref, meas, state) -> None:
    """Compile the geometry's ``reaction_rows`` (the run's reaction torque,
    :mod:`.diagnostics`) with the argument types the run passes (the second process, after
    :func:`_compile_real_kernels`)."""
    kernels = GEOMETRIES[type(geo)]
    fixed = kernels.true_model_constants(geo)
    n, N = meas.q_m.size, meas.w.size
    rows = kernels.reaction_rows_of(  # one recorded row of each: base_inertia's types too
        np.zeros((1, N - n)), np.zeros((1, n)), np.zeros((1, N)), np.zeros((1, N - n))
    )
    kernels.reaction_rows(*fixed, *rows, state.theta_d)


__all__ = [
    "GEOMETRIES", "SIGNALS", "KernelGains", "PeriodLaw", "PeriodOutputs", "PeriodState",
    "PeriodBox", "compile_in_parallel", "law_fields", "period", "period_box", "period_law",
    "period_of", "period_outputs",
]  # fmt: skip
