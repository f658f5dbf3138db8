"""ffsm_pin._cpu_time: the CPU time of work that hands rows to a helper thread
(control.diagnostics.rows_beside) counts the helper's time too, as the process's clock does."""

from __future__ import annotations

import time

import numpy as np

from ffsm_pin._cpu_time import ledger, work_time
from ffsm_pin.control.diagnostics import rows_beside


def _busy_rows(x: np.ndarray) -> np.ndarray:
    """A row-wise kernel that burns CPU (pure Python: the threads take turns on the GIL)."""
    out = np.empty(len(x))
    for i, v in enumerate(x):
        out[i] = v + sum(range(50_000))
    return out


def test_a_helper_threads_cpu_time_is_the_callers_work():
    rows = (np.arange(256.0),)
    cpu0 = time.thread_time()
    alone = _busy_rows(rows[0])  # the same rows in this thread alone
    single = time.thread_time() - cpu0
    thread0, work0 = time.thread_time(), work_time()
    result, other = rows_beside(_busy_rows, rows, lambda: "done")
    thread = time.thread_time() - thread0
    work = work_time() - work0
    assert other == "done" and np.array_equal(result, alone)
    assert single > 0.05  # (a measurable time)
    assert thread < 0.8 * single  # the helper did a share of the rows ...
    # ... and its time is counted as this thread's: the same work as alone (the clocks of
    # the two threads: other threads of the process, pytest's or Dask's, are not in them)
    assert abs(work - single) < 0.25 * single


def test_a_threads_ledger_is_its_own():
    import threading

    mine = ledger()
    seen = []
    t = threading.Thread(target=lambda: seen.append(ledger()))
    t.start()
    t.join()
    assert seen[0] is not mine and ledger() is mine
