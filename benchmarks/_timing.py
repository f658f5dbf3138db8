"""Timing helper shared by the benchmarks.

``time_call(fn, repeat=..., number=...)`` runs ``fn()`` ``number`` times per sample, takes
``repeat`` samples with :func:`time.perf_counter` and returns the median and the quartiles
of the per-call time in microseconds. ``number=None`` picks it so that one sample lasts
about ``target_s`` (like :meth:`timeit.Timer.autorange`). The garbage collector is off
while a sample runs (as in :mod:`timeit`), and one untimed call warms caches first.

``time_interleaved`` does the same for several callables, taking their samples in
round-robin order, so a change of machine load during the run hits every item alike and
the ratios between items stay meaningful on a busy machine.

``checkout(root)`` names what a benchmark measured: ``HEAD <short hash>``, and
``(+ the working tree)`` when tracked files differ from it.
"""

from __future__ import annotations

import gc
import statistics
import subprocess
import time
from collections.abc import Callable, Mapping
from typing import NamedTuple

__all__ = ["Timing", "checkout", "time_call", "time_interleaved"]


class Timing(NamedTuple):
    """Per-call time in microseconds: median and first/third quartiles over the samples."""

    median_us: float
    q1_us: float
    q3_us: float

    @property
    def iqr_us(self) -> float:
        return self.q3_us - self.q1_us


def _sample(fn: Callable[[], object], number: int) -> float:
    """Seconds per call, averaged over ``number`` back-to-back calls."""
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        return (time.perf_counter() - t0) / number
    finally:
        if gc_was_enabled:
            gc.enable()


def _calibrate(fn: Callable[[], object], target_s: float) -> int:
    """Smallest number in 1, 2, 5, 10, 20, ... whose sample lasts at least target_s."""
    number = 1
    while True:
        for k in (1, 2, 5):
            n = number * k
            if _sample(fn, n) * n >= target_s:
                return n
        number *= 10


def _summary(samples: list[float]) -> Timing:
    us = [s * 1e6 for s in samples]
    if len(us) == 1:
        return Timing(us[0], us[0], us[0])
    q1, med, q3 = statistics.quantiles(us, n=4, method="inclusive")
    return Timing(med, q1, q3)


def time_call(
    fn: Callable[[], object],
    *,
    repeat: int = 31,
    number: int | None = None,
    target_s: float = 2e-3,
) -> Timing:
    """Time ``fn()``: median and quartiles of ``repeat`` samples, in microseconds per call.

    Parameters
    ----------
    fn:
        Callable without arguments (use ``functools.partial`` or a lambda).
    repeat:
        Number of samples.
    number:
        Calls per sample; ``None`` chooses it so that a sample lasts about ``target_s``.
    target_s:
        Sample duration aimed at when ``number`` is ``None`` [s].
    """
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    fn()  # warm-up
    n = _calibrate(fn, target_s) if number is None else int(number)
    if n < 1:
        raise ValueError(f"number must be >= 1, got {number}")
    return _summary([_sample(fn, n) for _ in range(repeat)])


def time_interleaved(
    fns: Mapping[str, Callable[[], object]],
    *,
    repeat: int = 31,
    number: int | None = None,
    target_s: float = 2e-3,
) -> dict[str, Timing]:
    """Like :func:`time_call` for several callables, sampled round-robin.

    Returns ``{name: Timing}`` in the order of ``fns``.
    """
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    counts = {}
    for name, fn in fns.items():
        fn()  # warm-up
        counts[name] = _calibrate(fn, target_s) if number is None else int(number)
    samples: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            samples[name].append(_sample(fn, counts[name]))
    return {name: _summary(s) for name, s in samples.items()}


def checkout(root) -> str:
    """``HEAD <short hash>`` of the git checkout at ``root``, with ``(+ the working tree)``
    when its tracked files differ from HEAD."""
    git = ["git", "-C", str(root)]
    head = subprocess.run([*git, "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()  # fmt: skip
    dirty = subprocess.run([*git, "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()  # fmt: skip
    return f"HEAD {head}{' (+ the working tree)' if dirty else ''}"
