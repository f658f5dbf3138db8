"""Compiled (numba) array helpers the compiled kernels of every layer use (the models' and
the control periods'): copies into part of an array and a matrix-vector product, by loops."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _put(dst, start, src):
    """``dst[start : start + src.size] = src`` for vectors, by a loop: the same values, but a
    slice assignment from an array makes numba compile the code of its shape-mismatch message,
    about a second of a first run's critical path per array rank."""
    for i in range(src.size):
        dst[start + i] = src[i]


@njit(cache=True)
def _put_rows(dst, src):
    """``dst[: src.shape[0], : src.shape[1]] = src`` for matrices, by a loop (see :func:`_put`)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@njit(cache=True)
def _mv(A, x):
    """A @ x for a real matrix A and a real or complex vector x (dtype of x)."""
    out = np.zeros(A.shape[0], dtype=x.dtype)
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[i] += A[i, j] * x[j]
    return out


__all__ = ["_mv", "_put", "_put_rows"]
