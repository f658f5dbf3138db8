"""The barycentric pseudo-inertia P(theta_d): the linear map whose positive semidefiniteness
makes an estimate of theta_d physical (docs/robust.md section 1).

theta_d is a linear image of a positive semidefinite matrix built from the bodies' masses and
inertias (docs/robust.md section 1 derives both):

* planar: the Hermitian (n+1)x(n+1) ``H_kl = Dc_kl + i Ds_kl = sum_i m_i conj(w_ik) w_il +
  I_k delta_kl`` (each 2-vector W_ik a complex number), written as the real symmetric
  ``[[Re H, -Im H], [Im H, Re H]]`` of size 2(n+1) (its eigenvalues are H's, each twice); a
  collinear robot (no Ds) has H real and P = H, size n+1;
* spatial: the 3(n+1) block matrix with diagonal blocks ``tr(Jbar_k)/2 E - Jbar_k`` (= Sigma_k
  + D_kk, Sigma_k body k's second moment about its CoM) and off-diagonal blocks D_kl
  (D_lk = D_kl^T).

Either way ``P(theta_d) >= eps I`` gives ``M(q, theta_d) > 0`` at every configuration, and the
true theta_d has ``P >= 0``. What differs between the geometries is only the table of the map
(:class:`PseudoInertiaTable`: which entry of theta_d goes, with which factor, to which entry of
P), made by :func:`planar_table` or :func:`spatial_table`; one numpy reference
(:func:`pseudo_inertia`, :func:`pseudo_inertia_adjoint`) and one compiled version
(:func:`assemble`, :func:`adjoint`) read any table.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit


class PseudoInertiaTable(NamedTuple):
    """The linear map theta_d -> P as a list of entries: ``P[rows[e], cols[e]] +=
    coefs[e] * theta_d[params[e]]`` (both triangles listed; P symmetric, ``size`` x ``size``)."""

    rows: np.ndarray  # (E,) int64
    cols: np.ndarray  # (E,) int64
    params: np.ndarray  # (E,) int64, the entry of theta_d
    coefs: np.ndarray  # (E,) float
    size: int


def _table(entries: list[tuple[int, int, int, float]], size: int) -> PseudoInertiaTable:
    r, c, p, f = zip(*entries, strict=True)
    rows, cols, params = (np.array(x, dtype=np.int64) for x in (r, c, p))
    return PseudoInertiaTable(rows, cols, params, np.array(f, dtype=float), size)


def _pairs(nb: int) -> list[tuple[int, int]]:
    return [(k, l) for k in range(nb) for l in range(k + 1, nb)]


def planar_table(n_bodies: int, collinear: bool) -> PseudoInertiaTable:
    """The table of a planar layout ``theta_d = (Dc_kk, Dc_kl (k<l), [Ds_kl (k<l)])``.

    Parameters
    ----------
    n_bodies : int
        n + 1.
    collinear : bool
        The collinear layout (no Ds_kl): P = Re H, size n + 1.

    Returns
    -------
    PseudoInertiaTable
        The map theta_d -> P.
    """
    nb = n_bodies
    pairs = _pairs(nb)
    copies = (0,) if collinear else (0, nb)  # Re H on both diagonal blocks of the real form
    e = [(s + k, s + k, k, 1.0) for s in copies for k in range(nb)]
    for j, (k, l) in enumerate(pairs):
        e += [(s + a, s + b, nb + j, 1.0) for s in copies for a, b in ((k, l), (l, k))]
        if not collinear:  # Im H in [[., -Im H], [Im H, .]], Im H antisymmetric
            js = nb + len(pairs) + j
            e += [(nb + k, l, js, 1.0), (nb + l, k, js, -1.0), (k, nb + l, js, -1.0),
                  (l, nb + k, js, 1.0)]  # fmt: skip
    return _table(e, nb if collinear else 2 * nb)


#: the entries (i, j) of a symmetric 3x3 matrix in theta_d's order (xx, xy, xz, yy, yz, zz):
#: each body's inertia in the spatial layout (here, the lowest module that reads it;
#: :mod:`._spatial_layout` and the kernels import it)
SYM6 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def spatial_table(n_bodies: int) -> PseudoInertiaTable:
    """The table of the spatial layout ``theta_d = (Jbar_k as (xx, xy, xz, yy, yz, zz), D_kl
    for k<l row-major 3x3)``: diagonal blocks ``tr(Jbar_k)/2 E - Jbar_k``, blocks D_kl.

    Parameters
    ----------
    n_bodies : int
        n + 1.

    Returns
    -------
    PseudoInertiaTable
        The map theta_d -> P (size 3(n+1)).
    """
    nb = n_bodies
    e = []
    for k in range(nb):
        for s, (i, j) in enumerate(SYM6):
            p = 6 * k + s
            if i == j:  # tr(Jbar)/2 on the three diagonal entries, minus J_ii on its own
                e += [(3 * k + a, 3 * k + a, p, 0.5 - (a == i)) for a in range(3)]
            else:
                e += [(3 * k + i, 3 * k + j, p, -1.0), (3 * k + j, 3 * k + i, p, -1.0)]
    for q, (k, l) in enumerate(_pairs(nb)):
        for i in range(3):
            for j in range(3):
                p = 6 * nb + 9 * q + 3 * i + j
                e += [(3 * k + i, 3 * l + j, p, 1.0), (3 * l + j, 3 * k + i, p, 1.0)]
    return _table(e, 3 * nb)


def pseudo_inertia(table: PseudoInertiaTable, theta_d) -> np.ndarray:
    """P(theta_d), the numpy reference of :func:`assemble`.

    Parameters
    ----------
    table : PseudoInertiaTable
        The model's map.
    theta_d : array_like
        Dynamic parameters (Eq. 12).

    Returns
    -------
    ndarray, shape (size, size)
        The symmetric pseudo-inertia.
    """
    P = np.zeros((table.size, table.size))
    np.add.at(P, (table.rows, table.cols), table.coefs * np.asarray(theta_d)[table.params])
    return P


def pseudo_inertia_adjoint(table: PseudoInertiaTable, v, n_d: int) -> np.ndarray:
    """The gradient a of ``theta_d -> v^T P(theta_d) v`` (so ``v^T P v = a . theta_d``), the
    numpy reference of :func:`adjoint`.

    Parameters
    ----------
    table : PseudoInertiaTable
        The model's map.
    v : array_like, shape (size,)
        A vector.
    n_d : int
        Size of theta_d.

    Returns
    -------
    ndarray, shape (n_d,)
        The gradient.
    """
    v = np.asarray(v, dtype=float)
    a = np.zeros(n_d)
    np.add.at(a, table.params, table.coefs * v[table.rows] * v[table.cols])
    return a


@njit(cache=True)
def assemble(rows, cols, params, coefs, size, theta_d):
    """P(theta_d) from a table's arrays (as :func:`pseudo_inertia`).

    Parameters
    ----------
    rows, cols, params, coefs : ndarray
        The fields of a :class:`PseudoInertiaTable`.
    size : int
        Its size.
    theta_d : ndarray
        Dynamic parameters.
    """
    P = np.zeros((size, size))
    for e in range(rows.size):
        P[rows[e], cols[e]] += coefs[e] * theta_d[params[e]]
    return P


@njit(cache=True)
def adjoint(rows, cols, params, coefs, v, n_d):
    """The gradient of ``v^T P(theta_d) v`` in theta_d (as :func:`pseudo_inertia_adjoint`).

    Parameters
    ----------
    rows, cols, params, coefs : ndarray
        The fields of a :class:`PseudoInertiaTable`.
    v : ndarray
        A vector of P's size.
    n_d : int
        Size of theta_d.
    """
    a = np.zeros(n_d)
    for e in range(rows.size):
        a[params[e]] += coefs[e] * v[rows[e]] * v[cols[e]]
    return a


__all__ = [
    "PseudoInertiaTable", "adjoint", "assemble", "planar_table", "pseudo_inertia",
    "pseudo_inertia_adjoint", "spatial_table",
]  # fmt: skip
