"""Compiled kernels for the spatial controller period (:mod:`ffsm_pin.control.fast_spatial`).

Dtype-generic (real or complex128) companions of :mod:`ffsm_pin.spatial._kernels`, used
inside the complex-step evaluation of the kinematic law: every scratch array takes the dtype of
the output array passed in, so numba compiles a complex specialisation whose imaginary part
carries the exact directional derivative.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._kernels import _add_st, _mm, _mmt


@njit(cache=True)
def base_columns(R, z, theta, Mc):
    """Mc (N, 3) = the first three columns of M(q, theta_d) (Eq. 9a), i.e. the transposed
    momentum rows (H_bb H_bm) of Eq. (13); the same sums as
    :func:`ffsm_pin.spatial._kernels.mass_matrix` restricted to the base columns. Real or
    complex (dtype of Mc)."""
    nb = R.shape[0]
    Mc[:] = 0.0
    J = np.empty((3, 3), dtype=Mc.dtype)
    T1 = np.empty((3, 3), dtype=Mc.dtype)
    B = np.empty((3, 3), dtype=Mc.dtype)
    for k in range(nb):
        t = theta[6 * k : 6 * k + 6]
        J[0, 0], J[0, 1], J[0, 2] = t[0], t[1], t[2]
        J[1, 0], J[1, 1], J[1, 2] = t[1], t[3], t[4]
        J[2, 0], J[2, 1], J[2, 2] = t[2], t[4], t[5]
        _mm(R[k], J, T1)
        _mmt(T1, R[k], B)
        for c in range(3):  # S_k e_c = e_c for the base columns
            _add_st(Mc, c, k, z, B[0, c], B[1, c], B[2, c], False)
    p = 6 * nb
    D = np.empty((3, 3), dtype=Mc.dtype)
    X = np.empty((3, 3), dtype=Mc.dtype)
    Km = np.empty((3, 3), dtype=Mc.dtype)
    for k in range(nb):
        for l in range(k + 1, nb):
            for i in range(3):
                for j in range(3):
                    D[i, j] = theta[p + 3 * i + j]
            p += 9
            _mm(R[k], D, T1)
            _mmt(T1, R[l], X)
            tr = X[0, 0] + X[1, 1] + X[2, 2]
            for i in range(3):
                for j in range(3):
                    Km[i, j] = -X[j, i]
                Km[i, i] += tr
            for c in range(3):  # S_k^T K S_l e_c, S_l^T K^T S_k e_c
                _add_st(Mc, c, k, z, Km[0, c], Km[1, c], Km[2, c], False)
                _add_st(Mc, c, l, z, Km[c, 0], Km[c, 1], Km[c, 2], False)
