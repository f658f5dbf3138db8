"""CPU time of work that hands part of itself to helper threads.

``time.thread_time()`` counts the calling thread only; a run that computes its after-run signals
on a second thread (:func:`ffsm_pin.control.diagnostics.rows_beside`) would leave that thread's
CPU time out of a campaign case's ``case_cpu_s``. A helper thread adds what it spent to the
ledger of the thread it works for (:func:`ledger`, taken in that thread before the helper
starts), and :func:`work_time` is the calling thread's own CPU time plus its helpers' [s].
``time.process_time()`` would count every thread of the process, also those of other work
running beside (a Dask worker with several threads).
"""

from __future__ import annotations

import threading
import time

__all__ = ["Ledger", "ledger", "work_time"]

_local = threading.local()


class Ledger:
    """CPU seconds helper threads spent for one thread (they add, that thread reads)."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self._lock = threading.Lock()

    def add(self, seconds: float) -> None:
        """Book ``seconds`` [s] of a helper thread's CPU time."""
        with self._lock:
            self.seconds += seconds


def ledger() -> Ledger:
    """The calling thread's ledger (made on first use): hand it to a helper thread.

    Returns
    -------
    Ledger
        The calling thread's ledger.
    """
    book = getattr(_local, "ledger", None)
    if book is None:
        book = _local.ledger = Ledger()
    return book


def work_time() -> float:
    """The calling thread's CPU time and its helpers' so far [s] (differences are meaningful,
    as with ``time.thread_time``).

    Returns
    -------
    float
        CPU seconds.
    """
    return time.thread_time() + ledger().seconds
