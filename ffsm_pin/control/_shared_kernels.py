"""Compiled pieces shared by the planar and the spatial control periods.

The status codes a period returns, the packed layouts of a funnel, of the gains and of the
null-space option, and the kernels both geometries use the same way: the funnel transformation
(Eqs. 18-22), the Fourier reference and the determinant of an SPD matrix. Each is checked
against its numpy reference through the periods (``tests/control/test_fast*.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._array_kernels import _mv
from .null_space import GRADIENT_STEP, OBJECTIVE_CODE

STATUS_OK = 0
STATUS_FUNNEL_Z = 1  # end-effector error left its funnel
STATUS_FUNNEL_B = 2  # attitude error left its funnel
STATUS_M_NOT_PD = 3  # M(q, theta_d-hat) not positive definite
STATUS_BASE_ROW = 4  # singular base row of the filter
STATUS_H_COLLAPSE = 5  # |H_bm-hat| ~ 0
STATUS_NONFINITE = 6  # u_m not finite

# rows of a packed funnel array (8, m)
F_R0, F_RI, F_BETA, F_A, F_B1, F_B2, F_UP, F_LO = range(8)
# entries of the packed null-space array (pack_null_space)
NS_CODE, NS_GAIN, NS_STEP, NS_CENTER = range(4)
#: the code of the joint-centering objective
NS_JOINT_CENTERING = OBJECTIVE_CODE["joint-centering"]
# entries of the packed gains array (gains_array); q_bd has m3 entries
G_KB, G_KZ, G_KDE, G_KD, G_G1, G_G2, G_G3, G_THR, G_QBD = range(9)


def gains_array(gains, threshold: float, q_bd) -> np.ndarray:
    """(8 + m3,) array: k_b, k_z, k_de, k_d, gamma_1..3, the singularity threshold [m], q_bd
    (the desired base attitude: angle [rad] or MRP)."""
    return np.array(
        [gains.k_b, gains.k_z, gains.k_de, gains.k_d, gains.gamma_1, gains.gamma_2,
         gains.gamma_3, threshold, *np.asarray(q_bd, dtype=float).reshape(-1)]
    )  # fmt: skip


def pack_funnel(funnel) -> np.ndarray:
    """(8, m) array of a :class:`~ffsm_pin.control.funnel.Funnel`'s constants."""
    return funnel.kernel_table()


def pack_null_space(null_space, center, n: int) -> np.ndarray | None:
    """(3 + n,) array of a :class:`~ffsm_pin.control.null_space.NullSpace`: objective code,
    gain, gradient step, joint-centering centre (zeros when unused); None when the objective
    is ``"none"``: the kernels test ``ns is not None``, which numba decides when it compiles,
    so a run without the null-space term does not compile its gradient (a first run's
    critical path, about 1-2 s)."""
    if OBJECTIVE_CODE[null_space.objective] == 0:
        return None
    out = np.zeros(3 + n)
    out[NS_CODE] = OBJECTIVE_CODE[null_space.objective]
    out[NS_GAIN] = null_space.gain
    out[NS_STEP] = GRADIENT_STEP
    if center is not None:
        out[NS_CENTER:] = center
    return out


@njit(cache=True)
def funnel_terms(f, t, e, identity):
    """(psi, Phi, exit index or -1) of Eqs. (18)-(22) for the packed funnel ``f`` (see
    :func:`pack_funnel`) at time ``t`` [s], in the dtype of the error ``e`` (real, or complex
    for a complex step in ``t`` or the state). The exit index is the component nearest to
    (or farthest beyond) its bound, as :class:`~ffsm_pin.control.funnel.Funnel` reports it;
    ``identity`` gives psi = e, Phi = 1 (no prescribed performance)."""
    m = e.size
    psi = np.empty(m, dtype=e.dtype)
    Phi = np.empty(m, dtype=e.dtype)
    if identity:
        for i in range(m):
            psi[i] = e[i]
            Phi[i] = 1.0
        return psi, Phi, -1
    rho = np.empty(m, dtype=e.dtype)  # complex when t is complex-stepped
    s = np.empty(m, dtype=e.dtype)
    worst, idx = np.inf, -1
    for i in range(m):
        rho[i] = (f[F_R0, i] - f[F_RI, i]) * np.exp(-f[F_BETA, i] * t) + f[F_RI, i]  # Eq. (18)
        s[i] = e[i] / rho[i]
        margin = min(f[F_UP, i] - s[i].real, s[i].real - f[F_LO, i])
        if margin < worst:
            worst, idx = margin, i
    if worst <= 0:
        return psi, Phi, idx
    for i in range(m):
        num = f[F_A, i] + f[F_B1, i] * s[i]
        den = f[F_A, i] + f[F_B2, i] * s[i]
        psi[i] = np.log(num / den)  # Eq. (21)
        Phi[i] = (f[F_B1, i] / num - f[F_B2, i] / den) / rho[i]  # Eq. (22)
    return psi, Phi, -1


@njit(cache=True)
def _reference(rc, rA, ramp, rfreq, rphase, rpp, t, rate):
    """z_e,d(t) (``rate`` False) or dz_e,d/dt: the harmonic terms plus, when ``rpp`` has
    segments, the piecewise polynomial of a reference from data (complex-step safe)."""
    arg = rfreq * t + rphase
    if rate:
        out = _mv(rA, -ramp * rfreq * np.sin(arg))
    else:
        out = rc + _mv(rA, ramp * np.cos(arg))
    if rpp.shape[1] > 0:
        out = out + _piecewise(rpp, t, 1 if rate else 0)
    return out


@njit(cache=True)
def _piecewise(table, t, order):
    """d^order/dt^order of :class:`ffsm_pin.scenario.trajectory.PiecewisePolynomial` at t
    (as its numpy ``derivative``; the segment is chosen by Re t)."""
    starts = table[0]
    tr = t.real
    lo, hi = 0, starts.size  # last k with starts[k] <= tr (0 when none)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if starts[mid] <= tr:
            lo = mid
        else:
            hi = mid
    tau = t - starts[lo]
    n = (table.shape[0] - 1) // 6
    out = np.zeros(n) + 0.0 * tau  # real or complex, as t
    for p in range(5, order - 1, -1):
        fac = 1.0
        for j in range(order):
            fac *= p - j
        for i in range(n):
            out[i] = out[i] * tau + fac * table[1 + p * n + i, lo]
    return out


@njit(cache=True)
def damped_pinv(A, thr):
    """Damped right pseudo-inverse ``A^T (A A^T + lambda^2 E)^-1`` of a wide matrix (real or
    complex, complex-step safe), with the damping of
    :func:`ffsm_pin.control.linalg.damped_row_pinv`: lambda^2 = thr^2 - sigma^2 when the
    smallest singular value sigma of Re A is below ``thr``, else 0.

    Returns ``(pinv, sigma, lambda^2)``. One kernel for both geometries and the baselines.
    """
    gram = A @ A.T
    eig = np.linalg.eigvalsh(np.ascontiguousarray(gram.real))
    sigma = np.sqrt(max(eig[0], 0.0))
    damping = 0.0
    if sigma < thr:
        damping = thr * thr - sigma * sigma
        for i in range(gram.shape[0]):
            gram[i, i] += damping
    return A.T @ np.linalg.inv(gram), sigma, damping


@njit(cache=True)
def _spd_det(G):
    """det of an SPD matrix by elimination without pivoting (complex-step safe; as
    ffsm_pin.control.null_space.spd_det)."""
    G = G.copy()
    m = G.shape[0]
    det = G[0, 0] * 1.0
    for k in range(m):
        if k > 0:
            det = det * G[k, k]
        for i in range(k + 1, m):
            f = G[i, k] / G[k, k]
            for j in range(k + 1, m):
                G[i, j] -= f * G[k, j]
    return det


@njit(cache=True)
def joint_centering_gradient(ns, q_m):
    """grad_{q_m} mu of the joint-centering objective mu = -1/2 |q_m - center|^2: center - q_m
    (``ns`` :func:`pack_null_space`; as :func:`ffsm_pin.control.null_space.null_space_gradient`)."""
    grad = np.empty(q_m.size, dtype=q_m.dtype)
    for j in range(q_m.size):
        grad[j] = ns[NS_CENTER + j] - q_m[j]
    return grad


@njit(cache=True)
def manipulability(A):
    """mu = sqrt(det(A A^T)) with the plain transpose, complex-step safe (as
    :func:`ffsm_pin.control.null_space.manipulability`); A = J_m-hat U-hat of Eq. (36)."""
    return np.sqrt(_spd_det(A @ A.T))


@njit(cache=True)
def perturbed_joints(q_m, h):
    """(2n, n): q_m + h e_j in row 2j, q_m - h e_j in row 2j + 1 (the central difference of
    :func:`manipulability_gradient`; ``h`` real [rad])."""
    n = q_m.size
    Q = np.empty((2 * n, n), dtype=q_m.dtype)
    for j in range(n):
        for k in range(n):
            Q[2 * j, k] = q_m[k]
            Q[2 * j + 1, k] = q_m[k]
        Q[2 * j, j] += h
        Q[2 * j + 1, j] -= h
    return Q


@njit(cache=True)
def manipulability_gradient(A, h):
    """grad_{q_m} mu by central differences: ``A[i]`` the geometry's J_m-hat U-hat at row i of
    :func:`perturbed_joints` (as :func:`ffsm_pin.control.null_space.null_space_gradient`)."""
    n = A.shape[0] // 2
    grad = np.empty(n, dtype=A.dtype)
    for j in range(n):
        grad[j] = (manipulability(A[2 * j]) - manipulability(A[2 * j + 1])) / (2.0 * h)
    return grad


@njit(cache=True)
def difference(A, B):
    """``A - B`` of two matrices of the same shape, by loops: the same values as numba's array
    expression, at about half its cost on the spatial regressors (10 x 300)."""
    out = np.empty(A.shape)
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[i, j] = A[i, j] - B[i, j]
    return out


@njit(cache=True)
def filter_regressor_update(Y_df, decay, gain, YM, YMdot, Yh):
    """Eq. (50) over one period, in place: ``Y_df <- decay Y_df + gain ((YM - YMdot) + Yh)``
    with ``decay = exp(-k_de dt)``, ``gain = (1 - exp(-k_de dt)) / k_de`` and Y_dc = Y_M(dw-hat
    /dt - k_de w~) - Y_Mdot + Y_h (as :func:`ffsm_pin.control.adaptation.regressor_filter_step`).
    Element by element in the order of the array expression it replaces, so the same values;
    one pass without temporaries (spatial 10 x 300: 3.4 us against 12 us)."""
    for i in range(Y_df.shape[0]):
        for j in range(Y_df.shape[1]):
            Y_df[i, j] = decay * Y_df[i, j] + gain * ((YM[i, j] - YMdot[i, j]) + Yh[i, j])


@njit(cache=True)
def positive_definite(A):
    """True when the symmetric real ``A`` is positive definite (M-hat of the filter, Eq. 46).

    A Cholesky factorisation by loops decides (5x5 to 10x10: 0.05-0.15 us against 1.2-3.8 us
    for LAPACK's eigenvalues inside a kernel); only when it meets a pivot that is not positive
    does LAPACK's smallest eigenvalue decide, the test the periods made before
    (``eigvalsh(A)[0] > 0``, that of the numpy reference). The two differ only for a matrix
    whose smallest eigenvalue is zero to rounding, where the factorisation may still complete.
    A decision, not a value: the periods' outputs are unchanged.
    """
    n = A.shape[0]
    L = np.empty((n, n))
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return np.linalg.eigvalsh(A)[0] > 0.0
        d = np.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, n):
            x = A[i, j]
            for k in range(j):
                x -= L[i, k] * L[j, k]
            L[i, j] = x / d
    return True


@njit(cache=True)
def smallest_singular_value_above(A, tol):
    """(``sigma_3(A) > tol``, sigma_3 or NaN) for a real 3x3 ``A`` (the base rows' matrix of
    Eqs. 60a, 64-65, spatial).

    sigma_3 >= 2 |det A| / |A|_F^2 (since sigma_1 sigma_2 <= (sigma_1^2 + sigma_2^2) / 2):
    when that bound, less a margin for its own rounding, exceeds ``tol`` the answer is True
    without an SVD (the value is then not needed and returned as NaN); otherwise LAPACK's
    SVD decides, as before. Bound: 0.1 us; SVD inside a kernel: about 2 us.
    """
    det = (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
           - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
           + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))  # fmt: skip
    fro2 = 0.0
    for i in range(3):
        for j in range(3):
            fro2 += A[i, j] * A[i, j]
    if fro2 > 0.0 and np.isfinite(det):  # (entries near 1e100: det overflows, SVD decides)
        # the determinant's rounding is below ~20 eps |A|^3, the bound's below ~20 eps |A|
        if 2.0 * abs(det) / fro2 - 64.0 * 2.220446049250313e-16 * np.sqrt(fro2) > tol:
            return True, np.nan
    smallest = np.linalg.svd(A)[1][2]
    return smallest > tol, smallest


@njit(cache=True)
def _solve(A, b):
    """``np.linalg.solve(A, b)`` as a cached kernel of its own: numba compiles its LAPACK
    wrapper (about 2 s, its shape-message code included) into every function that calls it
    directly, once per process; through this kernel a first run compiles it once, in its
    second process, and the periods load it from the cache. The same values."""
    return np.linalg.solve(A, b)


@njit(cache=True)
def theta_z_step(theta_z, Yz, z_e_dot, gamma_2, dt):
    """Eq. (42) by backward Euler on the position rows ``Yz`` of Y_z (as
    :func:`ffsm_pin.control.adaptation.theta_z_step`); ``z_e_dot`` the measured rates."""
    m = Yz.shape[0]
    r = z_e_dot[:m] - Yz @ theta_z
    gram = Yz @ Yz.T
    for i in range(m):
        gram[i, i] += 1.0 / (gamma_2 * dt)
    return theta_z + Yz.T @ _solve(gram, r)


@njit(cache=True)
def report_kinematic(out, start, at_h, at_sigma, err_b, err_z, sigma, damping, hnorm, status,
                     idx):  # fmt: skip
    """Write what a period's kinematic level reports into ``out`` (the periods' ``out_layout``):
    the real parts of err_b then err_z from ``start``; |H_bm| at ``at_h`` and, on a funnel
    exit (``idx`` >= 0), the exiting error component at ``at_h + 1``; sigma_min and the
    damping at ``at_sigma``."""
    for i in range(err_b.size):
        out[start + i] = err_b[i].real
    for i in range(err_z.size):
        out[start + err_b.size + i] = err_z[i].real
    out[at_sigma] = sigma
    out[at_sigma + 1] = damping
    out[at_h] = hnorm
    if status != STATUS_OK and idx >= 0:
        out[at_h + 1] = (err_z[idx] if status == STATUS_FUNNEL_Z else err_b[idx]).real
