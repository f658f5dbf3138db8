"""Recorder memory reused within a process: a campaign worker's cases take their large row
chunks from a :class:`ChunkPool` instead of fresh memory.

A case's recorder (:class:`~ffsm_pin.sim.recorder.Recorder`) holds its rows in arrays filled
with NaN before the run; a spatial case of the paper's controller records about 100 MB of
them. The C library serves an array that large with fresh pages from the operating system
and gives them back when it is freed, so every case pays the page faults of its rows again,
on a virtual machine much more than the kernel's zeroing (benchmarks/README.md, "Recorder
memory kept in the worker"). A worker runs one case after another with arrays of the same few
sizes, so the pool keeps such an array's memory once nothing uses it and hands it out again,
NaN-filled as new; arrays smaller than :data:`MIN_BYTES` are left to the C library, which
reuses them itself.

Safety: a chunk is handed out as a fresh array over a memoryview of its memory
(``np.frombuffer(chunk.data)``), and every view of it (a recorded signal, a slice of one)
keeps that array alive; the chunk comes back to the pool only when the last of them is
gone (``weakref.finalize``), so memory is never handed out while a result still reads it
(tests/sim/test_chunk_pool.py).
"""

from __future__ import annotations

import threading
import weakref

import numpy as np

__all__ = ["MIN_BYTES", "ChunkPool"]

#: [bytes] Arrays at least this large come from the pool (the C library keeps smaller ones).
MIN_BYTES = 16 * 2**20


class ChunkPool:
    """Float64 arrays handed out NaN-filled (as ``np.full``), their memory reused once no
    array uses it.

    A request of at least ``min_bytes`` is served by a kept chunk of exactly its size;
    when none is kept, every kept chunk is released first (a worker moving on to cases of
    other sizes holds no more memory than they need) and a new one is made. Smaller requests
    are plain ``np.full``.

    Parameters
    ----------
    min_bytes : int
        Requests at least this large [bytes] come from the pool; :data:`MIN_BYTES` by default.
    """

    def __init__(self, min_bytes: int = MIN_BYTES) -> None:
        self.min_bytes = int(min_bytes)
        self._free: dict[int, list[np.ndarray]] = {}  # size -> chunks nothing uses
        self._lock = threading.Lock()
        self.handed_out = 0  # chunks handed out
        self.reused = 0  # of them, kept ones

    @property
    def free_bytes(self) -> int:
        """Memory kept for reuse now [bytes]."""
        with self._lock:
            return sum(c.nbytes for chunks in self._free.values() for c in chunks)

    def full(self, shape: tuple[int, ...], fill_value: float = np.nan) -> np.ndarray:
        """``np.full(shape, fill_value)`` (float64, C order), on a kept chunk when one of its
        size is free.

        Parameters
        ----------
        shape : tuple of int
            The array's shape.
        fill_value : float
            Every entry's value.

        Returns
        -------
        ndarray
            The array (writable). Its chunk returns to the pool when it and every view of it
            are gone.
        """
        size = int(np.prod(shape))
        if 8 * size < self.min_bytes or size == 0:
            return np.full(shape, fill_value)
        with self._lock:
            self.handed_out += 1
            kept = self._free.get(size)
            chunk = kept.pop() if kept else None
            if chunk is None:
                self._free.clear()  # other sizes now: hold no more than the new cases need
            else:
                self.reused += 1
        if chunk is None:
            chunk = np.full(size, fill_value)
        else:
            chunk.fill(fill_value)
        head = np.frombuffer(chunk.data, dtype=np.float64)  # (a memoryview's: views' base)
        weakref.finalize(head, self._give_back, chunk)
        return head.reshape(shape)

    def _give_back(self, chunk: np.ndarray) -> None:
        with self._lock:
            self._free.setdefault(chunk.size, []).append(chunk)

    def clear(self) -> None:
        """Release every kept chunk."""
        with self._lock:
            self._free.clear()
