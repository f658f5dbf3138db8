"""The torque-free target's rotation step in one compiled call (:func:`.target.torque_free_step`,
whose numpy code is the readable reference; tests/sim/test_target_kernels.py holds them
together to rounding).

A capture run steps its target every plant step and, with ``[approach]``, predicts it over the
target sensor's delay every control period: in numpy about 160 us a step, most of a capture
run's time. The same arithmetic compiled: the fourth-order symmetric splitting of Euler's
equations (exact axis rotations), the polar factor onto SO(3), and the body rates from the
kept world momentum. Compiling it takes 5-8 s once per installation (numba's cache; a run with
a target compiles it at its first step).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _axis_rotation(k, angle):
    """The rotation by ``angle`` [rad] about the k-th coordinate axis."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (k + 1) % 3, (k + 2) % 3
    out = np.eye(3)
    out[i, i] = c
    out[j, j] = c
    out[j, i] = s
    out[i, j] = -s
    return out


@njit(cache=True)
def _strang(Rp, pi, moments, h):
    """One symmetric splitting step of size h, in place (:func:`.target._strang`)."""
    for k, frac in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        rot = _axis_rotation(k, frac * h * pi[k] / moments[k])
        Rp[:] = Rp @ rot
        pi[:] = rot.T @ pi


@njit(cache=True)
def torque_free_rotation(R0, w0, L0, inertia, moments, Q, dt, c0, c1):
    """The attitude and body rates ``dt`` [s] after (R0, w0), torque-free, the world angular
    momentum kept at ``L0`` (:func:`.target.torque_free_step`'s rotation part).

    ``inertia`` (3, 3) about the CoM, body frame; ``moments`` and ``Q`` its principal moments
    and axes; ``c0``, ``c1`` the fourth-order composition's coefficients. Returns (R, w).
    """
    Rp = R0 @ Q
    pi = Q.T @ (inertia @ w0)
    for c in (c1, c0, c1):
        _strang(Rp, pi, moments, c * dt)
    u, _, vt = np.linalg.svd(Rp @ Q.T)
    R = u @ vt
    w = np.linalg.solve(inertia, R.T @ L0)
    return R, w
