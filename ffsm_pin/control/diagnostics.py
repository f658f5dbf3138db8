"""Quantities evaluated with the *true* model, for recording and analysis (never for control).

* :func:`reaction_torques`: the reaction torque of Eq. (7) on a run's recorded rows, from the
  base block of the inertia M_bb and its time derivative along the motion (the kernels'
  ``base_inertia``), computed after the run for every controller:
  ``F_r = M_bb dw_b/dt + 1/2 dM_bb/dt w_b`` (planar), plus the gyroscopic
  ``1/2 w_b x (M_bb w_b)`` for spatial robots, as the models' ``reaction_torque`` (tested
  against Pinocchio);
* :func:`rows_beside`: such a row-wise pass in pieces on a second thread and this one, beside
  other work (the run's after-run signals: F_r beside the momentum).

:func:`reaction_torques` returns a function; ``compiled=True`` gives the numba kernel of the
model's geometry (``reaction_rows`` of :mod:`.fast` or :mod:`.fast_spatial`, chosen by the
type of the model's kernel constants), ``False`` the numpy reference on the reduced model; the
two are tested against each other (tests/control/test_diagnostics.py).

The paper's Eq. (54) residual ``e = M w~ + Y_df (theta_d - theta_d-hat)`` with the true M and
theta_d, which the paper's controller reports (:mod:`.lu_jia`), is computed by the control
period itself (:class:`~.controller.CoordinatedController`, ``theta_d_true``), at the measured
state the period has already evaluated its terms at.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import numpy as np

from .._cpu_time import ledger
from ..model.interface import ReducedModel

#: rows per piece of work :func:`rows_beside` hands out (a piece costs 0.2-2 ms of a kernel)
ROWS_PER_PIECE = 256

T = TypeVar("T")


def reaction_torques(
    model: ReducedModel, theta_d: np.ndarray, compiled: bool
) -> Callable[..., np.ndarray]:
    """f(q_b, q_m, w, dw_b) -> F_r of Eq. (7) on N recorded rows with the true model: q_b
    (N, m3) [rad or MRP], q_m (N, n) [rad], w (N, n + m3) [rad/s], dw_b (N, m3) the base's
    angular acceleration (inertial frame) [rad/s^2]; planar (N,), spatial (N, 3) [N m].
    The compiled pass releases the GIL: :func:`rows_beside` runs it beside other work.

    Parameters
    ----------
    model : ReducedModel
        The true model.
    theta_d : ndarray
        Its dynamic parameters.
    compiled : bool
        Use the compiled kernels (else numpy).

    Returns
    -------
    callable
        f(q_b, q_m, w, dw_b) -> F_r [N m].
    """
    if compiled:
        kernels, fixed = _geometry_kernels(model)

        def rows_kernel(q_b, q_m, w, dw_b):
            return kernels.reaction_rows(*fixed, *kernels.reaction_rows_of(q_b, q_m, w, dw_b),
                                         theta_d)  # fmt: skip

        return rows_kernel
    m3 = model.m3

    def reference(q_b, q_m, w, dw_b):  # the model's reaction_torque, row by row
        out = np.empty((len(q_b),) if m3 == 1 else (len(q_b), m3))
        w_dot = np.zeros(w.shape[1])  # only the base rows enter Eq. (7)
        for i in range(len(q_b)):
            w_dot[:m3] = dw_b[i]
            qb = q_b[i, 0] if m3 == 1 else q_b[i]
            out[i] = model.reaction_torque(theta_d, qb, q_m[i], w[i], w_dot)
        return out

    return reference


def _geometry_kernels(model: ReducedModel) -> tuple[Any, tuple]:
    """The compiled kernels of the model's geometry (:data:`.period.GEOMETRIES`, by the type of
    its kernel constants) and the constant arguments their diagnostics take first."""
    from .period import GEOMETRIES

    geo = model.kernel_constants()
    kernels = GEOMETRIES[type(geo)]
    return kernels, kernels.true_model_constants(geo)


def rows_beside(
    kernel: Callable[..., np.ndarray], rows: tuple[np.ndarray, ...], beside: Callable[[], T]
) -> tuple[np.ndarray, T]:
    """(kernel(*rows), beside()): the row-wise ``kernel`` on pieces of ``rows`` (arrays of
    equal length), taken in turn by a second thread and, once ``beside`` has returned, by
    this one; the pieces joined in order. Rows are independent, so the values are the single
    pass's, bit for bit. Each piece is half of the rows left (at least
    :data:`ROWS_PER_PIECE`): the second thread needs the GIL only between pieces, which a
    ``beside`` that holds it (Pinocchio's momentum after a run) yields every 5 ms, and the
    last pieces are small, so the two threads end together when the kernel releases the GIL
    (numba's ``nogil``: the reaction torque after a run).

    Parameters
    ----------
    kernel : callable
        Row-wise function of the arrays of ``rows``.
    rows : tuple of ndarray
        Arrays of equal length.
    beside : callable
        Run in this thread meanwhile.

    Returns
    -------
    tuple
        (kernel(*rows), beside()).
    """
    n = len(rows[0])
    lock = threading.Lock()
    nxt = [0]
    done: dict[int, np.ndarray] = {}
    started = threading.Event()  # the second thread is about to enter its first piece

    def work() -> None:
        while True:
            with lock:
                a = nxt[0]
                if a >= n and done:  # (no rows: one empty piece, for the kernel's shape)
                    break
                b = min(n, a + max(ROWS_PER_PIECE, (n - a) // 2))
                nxt[0] = b
            started.set()  # (the second thread always takes the first piece)
            done[a] = kernel(*(r[a:b] for r in rows))
            if b >= n:
                break

    def give_up() -> None:  # on an error here: the second thread takes no further piece
        with lock:
            nxt[0] = n

    book = ledger()  # the helper's CPU time is this thread's work (a campaign case's CPU)

    def helped() -> None:
        cpu0 = time.thread_time()
        try:
            work()
        finally:
            book.add(time.thread_time() - cpu0)

    with ThreadPoolExecutor(1) as pool:
        helper = pool.submit(helped)
        try:
            started.wait()  # (else the second thread waits for the GIL that beside holds)
            other = beside()
            work()
        except BaseException:
            give_up()
            raise
        helper.result()
    return np.concatenate([done[a] for a in sorted(done)]), other
