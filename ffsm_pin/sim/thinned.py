"""A thinned view of recorded signals: every ``step``-th row and the last, read on first use
(:meth:`ffsm_pin.sim.result.RunResult.thinned`, for figures and replays of long runs)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np

from .recorder import Signals


class Thinned(Mapping):
    """Every ``step``-th row (and the last) of the per-row signals of ``signals``, read on
    first use and kept in memory; the ``constants`` (no time axis) are passed through.

    Parameters
    ----------
    signals : mapping of str to ndarray
        The recorded signals ("t" among them).
    step : int
        Row stride.
    constants : iterable of str
        Keys without a time axis.
    """

    def __init__(self, signals: Mapping[str, np.ndarray], step: int, constants=()):
        self._signals, self._step = signals, int(step)
        self._constants = set(constants)
        self._rows = len(signals["t"])
        self._cache: dict[str, np.ndarray] = {}

    def __getitem__(self, key: str) -> np.ndarray:
        if key not in self._cache:
            arr = self._signals[key]
            if key in self._constants or np.ndim(arr) == 0:
                self._cache[key] = arr
            elif isinstance(self._signals, Signals):
                self._cache[key] = self._signals.every(key, self._step)
            else:
                idx = np.arange(0, self._rows, self._step)
                if idx[-1] != self._rows - 1:
                    idx = np.append(idx, self._rows - 1)
                self._cache[key] = np.asarray(arr)[idx]
        return self._cache[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._signals)

    def __len__(self) -> int:
        return len(self._signals)
