"""The paper's control period, compiled once for both geometries.

One period (Eqs. 28, 42, 25+36 or 81, 46, 49-52, 60-64; docs/model.md) is the same
sequence of steps for a planar robot (m3 = 1) and a spatial one (m3 = 3): the geometry's terms
at the measured state and the estimators' steps (Eqs. 28, 42), the kinematic law evaluated
once with complex arguments ``x + i h dx/dt`` (its real part ``w_mc``, its imaginary part over
h the exact ``dw_mc/dt``), the report of the kinematic level, the dynamic level (Eqs. 46,
49-52, 60-64), the updates of the estimators and the outputs. :func:`period` writes that
sequence once. What differs is how each step is computed from the robot's geometry: a
planar robot's body angles and closed-form products, a spatial robot's rotations, MRP
attitudes and 3x3 solves. Those three steps (:func:`geometry_terms`, :func:`kinematic_law`,
:func:`dynamic_level`) are the geometry's compiled kernels (:mod:`.fast` for
:class:`~ffsm_pin.model.planar.PlanarKernelConstants`, :mod:`.fast_spatial` for
:class:`~ffsm_pin.model.spatial.SpatialKernelConstants`), chosen by numba when it compiles
:func:`period` from the type of the model's constants (the table :data:`GEOMETRIES`), so the
choice costs nothing per period and each geometry's arithmetic is exactly its own.

The readable reference is the numpy controller (:class:`~.controller.CoordinatedController`
with ``backend = "numpy"``); ``tests/control/test_fast.py`` and ``test_fast_spatial.py`` check
the two against each other, planar and spatial.

Outputs: :func:`period` returns (status, exit index) with the ``STATUS_*`` codes of
:mod:`._shared_kernels` and writes ``out`` as :func:`out_layout` says.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import overload

from .._array_kernels import _put
from .._arrays import read_only
from ..model.planar import PlanarKernelConstants
from ..model.spatial import SpatialKernelConstants
from . import _first_compile, fast, fast_spatial
from ._shared_kernels import (  # noqa: F401 - re-exported for the controller
    STATUS_BASE_ROW,
    STATUS_FUNNEL_B,
    STATUS_FUNNEL_Z,
    STATUS_H_COLLAPSE,
    STATUS_M_NOT_PD,
    STATUS_NONFINITE,
    STATUS_OK,
    gains_array,
    pack_funnel,
    pack_null_space,
    report_kinematic,
)

__all__ = [
    "GEOMETRIES",
    "SIGNALS",
    "compile_in_parallel",
    "gains_array",
    "out_layout",
    "pack_funnel",
    "pack_null_space",
    "period",
]

#: The compiled kernels of each geometry, by the type of the model's kernel constants. Each
#: module provides the period's three steps (``geometry_terms``, ``kinematic_law``,
#: ``dynamic_level``, with the signatures of the stubs below; the last also gives the
#: diagnostic e of Eq. 54), the true-model reaction torque ``reaction_rows``
#: (:mod:`.diagnostics`), and three small functions the first compilation and the
#: diagnostics use: ``base_velocity(w)``,
#: ``true_model_constants(geo)`` and ``reaction_rows_of(q_b, q_m, w, dw_b)``.
GEOMETRIES: dict[type, Any] = {
    PlanarKernelConstants: fast,
    SpatialKernelConstants: fast_spatial,
}

_H = 1e-30  # the complex step, as in control/kinematic.py


#: The signals :func:`period` writes side by side at the end of ``out``, in this order.
SIGNALS = ("w_tilde", "e", "theta_z_hat", "theta_d_hat", "theta_b_hat", "w_hat", "w_mc",
           "sigma_min", "damping")  # fmt: skip


def out_layout(
    n: int, m3: int, n_task: int, signals: Mapping[str, tuple[int, ...]]
) -> dict[str, Any]:
    """Where :func:`period` writes each output in ``out``: u_m, dw_mc/dt, err_b, err_z,
    |H_bm|, the exiting error component, then the block ``signals`` (each signal also by
    name): n joints, m3 attitude coordinates (1 planar, 3 spatial), n_task task rows, and
    the shapes of the signals the period reports, in the order it writes them (w~, e, the
    estimates and w-hat at t, w_mc, sigma_min, damping:
    :attr:`~.controller.CoordinatedController.signal_layout`)."""
    if tuple(signals) != SIGNALS:  # the order `period` writes them in
        raise ValueError(f"out_layout: the signals must be {SIGNALS}, in this order")
    h = 2 * n + m3 + n_task
    lay: dict[str, Any] = {
        "u_m": slice(0, n), "w_mc_dot": slice(n, 2 * n), "err_b": slice(2 * n, 2 * n + m3),
        "err_z": slice(2 * n + m3, h), "H_bm_norm": h, "exit_value": h + 1,
    }  # fmt: skip
    start = h + 2
    for key, shape in signals.items():
        stop = start + math.prod(shape)
        lay[key] = slice(start, stop) if shape else start
        start = stop
    lay["signals"] = slice(h + 2, start)
    lay["size"] = start
    return lay


# ---------------------------------------------------------------------- the geometry's steps
def geometry_terms(geo, adaptive, g, dt, q_b, q_m, w, w_hat, z_e_dot, theta_b, theta_z, theta_d):
    """The geometry's terms at the measured state, and Eqs. (28), (42) over the period.

    Returns ``(terms, theta_b(t + dt), theta_z(t + dt), dq_b/dt, w_b)``: ``terms`` what the
    dynamic level reuses (geometry-specific), the estimates after the period (unchanged when
    ``adaptive`` is False), the attitude's rate (Eq. 1) and the base's angular velocity.
    Compiled per geometry (:data:`GEOMETRIES`); this Python body is never run.
    """
    raise NotImplementedError


def kinematic_law(geo, nt, attitude, identity, fb, fz, g, rc, rA, ramp, rfreq, rphase, rpp, ns,
                  t, q_b, q_m, z_e, theta_b, theta_z, w_b):  # fmt: skip
    """w_mc of Eqs. (25)+(36) or (81) at complex arguments: (w_mc, d w_mc / d w_b, sigma_min,
    damping, |H_bm|, err_b, err_z, status, exit index). Compiled per geometry."""
    raise NotImplementedError


def dynamic_level(geo, terms, adaptive, g, dt, w, w_mc, w_mc_dot, sens, M_true, h_true,
                  theta_d, w_hat, Y_df, theta_d_true):  # fmt: skip
    """Eqs. (46), (49)-(52), (60)-(64): (status, exit value, u_m, w_mc_dot fed with the
    base's acceleration, w~, e); advances theta_d-hat, w-hat and Y_df in place when the status
    is ``STATUS_OK``. ``e`` the diagnostic e of Eq. (54) with the true M and ``theta_d_true``
    (empty when ``theta_d_true`` is). Compiled per geometry."""
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
        _overload(stub, cls, getattr(kernels, stub.__name__).py_func)


#: The jit options of the steps compiled through :func:`_overload`: those of the kernels'
#: ``@njit(cache=True)``. numba keys a cache entry by the function and the argument types,
#: not the options, so both must compile the same code: overload's default
#: ``no_cpython_wrapper=True`` would leave a cache entry that a call from Python (the second
#: process, a test) loads and crashes on.
_JIT_OPTIONS: Any = {"nopython": True, "cache": True, "no_cpython_wrapper": False}


def _overload(stub: Any, cls: type, impl: Any) -> None:
    @overload(stub, jit_options=_JIT_OPTIONS, strict=False)
    def _typed(geo, *args):
        if isinstance(geo, types.BaseNamedTuple) and geo.instance_class is cls:
            return impl
        return None  # another geometry's


for _cls, _kernels in GEOMETRIES.items():
    _register(_cls, _kernels)


# ---------------------------------------------------------------------- one period
@njit(cache=True)
def period(geo, nt, attitude, identity, adaptive, fb, fz, g, rc, rA, ramp, rfreq, rphase, rpp,
           ns, dt, t, q_b, q_m, w, z_e, z_e_dot, M_true, h_true,
           theta_z, theta_d, theta_b, w_hat, Y_df, theta_d_true, out):  # fmt: skip
    """One control period; updates the estimator states in place, writes ``out`` (see
    :func:`out_layout`) and returns (status, exit index).

    ``geo`` the model's kernel constants (its type selects the geometry's kernels), ``nt``
    the task rows, ``attitude`` False for scheme no-attitude (Eq. 81), ``identity`` True for
    no-ppc, ``adaptive`` False for known-model (Pinocchio's reduced M and C w passed as
    ``M_true``, ``h_true``; not read otherwise). ``fb``, ``fz`` the packed funnels, ``g``
    :func:`gains_array`, ``rc`` ... ``rpp`` the reference's arrays, ``ns`` the packed
    null-space option or None; the measurement at ``t`` [s]; the controller's states,
    advanced to ``t + dt``. ``theta_d_true``: the true theta_d, for the diagnostic e of
    Eq. (54) alone (written to ``out``; never read by the law), or empty (e not computed,
    its slot of ``out`` not written).
    """
    n, N = q_m.size, w.size
    # the signal block of `out` (out_layout): w~, e, the estimates and w-hat at t, w_mc,
    # sigma_min, damping; the estimates and w-hat written now, before they advance
    s = n + N + nt + 2
    at_est = s + 2 * N
    _put(out, at_est, theta_z)
    _put(out, at_est + theta_z.size, theta_d)
    _put(out, at_est + theta_z.size + theta_d.size, theta_b)
    at_w_hat = at_est + theta_z.size + theta_d.size + theta_b.size
    _put(out, at_w_hat, w_hat)
    at_w_mc = at_w_hat + N  # then sigma_min and the damping
    terms, tb_new, tz_new, q_b_rate, w_b = geometry_terms(
        geo, adaptive, g, dt, q_b, q_m, w, w_hat, z_e_dot, theta_b, theta_z, theta_d
    )  # Eqs. (28), (42)

    # kinematic level, value and exact derivative in one complex evaluation
    hj = 1j * _H
    w_mc_c, sens, sigma, damping, hnorm, err_b, err_z, status, idx = kinematic_law(
        geo, nt, attitude, identity, fb, fz, g, rc, rA, ramp, rfreq, rphase, rpp, ns,
        t + hj, q_b + hj * q_b_rate, q_m + hj * w[w.size - n:], z_e + hj * z_e_dot,
        theta_b + hj * (tb_new - theta_b) / dt, theta_z + hj * (tz_new - theta_z) / dt,
        w_b + 0j,
    )  # fmt: skip
    report_kinematic(out, 2 * n, s - 2, at_w_mc + n, err_b, err_z, sigma, damping, hnorm,
                     status, idx)  # fmt: skip
    if status != STATUS_OK:
        return status, idx
    w_mc = w_mc_c.real.copy()
    w_mc_dot = w_mc_c.imag / _H

    status, value, u_m, w_mc_dot_fed, w_tilde, e_54 = dynamic_level(
        geo, terms, adaptive, g, dt, w, w_mc, w_mc_dot, np.ascontiguousarray(sens), M_true,
        h_true, theta_d, w_hat, Y_df, theta_d_true,
    )  # fmt: skip
    if status != STATUS_OK:
        if status == STATUS_BASE_ROW:
            out[s - 1] = value  # the smallest singular value of the base rows' matrix
        return status, -1
    if adaptive:
        _put(theta_b, 0, tb_new)
        _put(theta_z, 0, tz_new)
    _put(out, 0, u_m)
    _put(out, n, w_mc_dot_fed)
    _put(out, s, w_tilde)
    _put(out, s + N, e_54)  # (nothing when not computed)
    _put(out, at_w_mc, w_mc)
    return STATUS_OK, -1


# ---------------------------------------------------------------------- first compilation
def compile_in_parallel(consts, t, q_b, q_m, w, z_e, theta_z, theta_d, theta_b) -> None:
    """On a first run, compile the geometry's real kernels (those :func:`period` calls, then
    the run's reaction torques) in a second process while this one compiles the geometry's
    complex kinematic law (:mod:`._first_compile`); :func:`period` then loads the former from
    the cache. ``consts`` the constant arguments of :func:`period` (the model's kernel
    constants first), the others the controller's initial measurement and estimates. Does
    nothing when the cache is warm."""
    kernels = GEOMETRIES[type(consts[0])]
    _first_compile.compile_in_parallel(
        __name__,
        (consts, q_b, q_m, w, z_e, theta_z, theta_d, theta_b),
        (kernels.kinematic_law,),
        lambda: kernels.kinematic_law(
            *_kinematic_args(kernels, consts, t, q_b, q_m, w, z_e, theta_z, theta_b)
        ),
    )


def _kinematic_args(kernels, consts, t, q_b, q_m, w, z_e, theta_z, theta_b) -> tuple:
    """Arguments of the geometry's ``kinematic_law`` with the types :func:`period` passes
    (complex values of the measurement's shapes); the values only need to be finite."""
    c = 1j * _H
    return (*consts[:4], *consts[5:], t + c, q_b + c, q_m + c, z_e + c, theta_b + c,
            theta_z + c, kernels.base_velocity(w) + 0j)  # fmt: skip


def _compile_real_kernels(consts, q_b, q_m, w, z_e, theta_z, theta_d, theta_b) -> None:
    """Compile the geometry's real steps of :func:`period` with the argument types it passes
    (the second process of :func:`compile_in_parallel`; ``z_e`` stands for the measured
    z_e_dot, of the same type)."""
    geo, adaptive, g = consts[0], consts[4], consts[7]
    kernels = GEOMETRIES[type(geo)]
    n, N = q_m.size, w.size
    terms, _, _, _, w_b = kernels.geometry_terms(
        geo, adaptive, g, 1e-3, q_b, q_m, w, np.zeros(N), z_e, theta_b, theta_z, theta_d
    )
    sens = np.zeros((n, *np.shape(w_b)))  # d w_mc / d w_b: (n,) planar, (n, 3) spatial
    M_true, h_true = read_only(np.zeros((N, N))), read_only(np.zeros(N))  # (as the period's)
    kernels.dynamic_level(
        geo, terms, adaptive, g, 1e-3, w, np.zeros(n), np.zeros(n), sens, M_true, h_true,
        theta_d.copy(), np.zeros(N), np.zeros((N, theta_d.size)), theta_d,
    )  # fmt: skip


def _compile_run_kernels(consts, q_b, q_m, w, z_e, theta_z, theta_d, theta_b) -> None:
    """Compile the geometry's ``reaction_rows`` (the run's reaction torque,
    :mod:`.diagnostics`) with the argument types the run passes (the second process, after
    :func:`_compile_real_kernels`)."""
    kernels = GEOMETRIES[type(consts[0])]
    fixed = kernels.true_model_constants(consts[0])
    n, N = q_m.size, w.size
    rows = kernels.reaction_rows_of(  # one recorded row of each: base_inertia's types too
        np.zeros((1, N - n)), np.zeros((1, n)), np.zeros((1, N)), np.zeros((1, N - n))
    )
    kernels.reaction_rows(*fixed, *rows, theta_d)
