"""Say on stderr when the controller kernels are about to be compiled (a cold numba cache)."""

from __future__ import annotations

import sys
from pathlib import Path

import ffsm_pin
from ffsm_pin._numba_cache import cache_folder

MESSAGE = "compiling the controller kernels (first run only, about 15-30 s)"


def cache_is_cold() -> bool:
    """True when no numba index (``*.nbi``) of this installation's controller kernels exists.

    Looks where numba keeps the entries of ``control/fast.py`` and ``control/fast_spatial.py``
    (:func:`ffsm_pin._numba_cache.cache_folder`: under ``NUMBA_CACHE_DIR``, set per user by
    :mod:`ffsm_pin`, or in ``__pycache__`` next to the sources).
    """
    control = Path(ffsm_pin.__file__).resolve().parent / "control"
    places = [cache_folder(control / name) for name in ("fast.py", "fast_spatial.py")]
    return not any(p.is_dir() and any(p.glob("fast*.nbi")) for p in places)


def note_compilation(quiet: bool) -> None:
    """Print :data:`MESSAGE` on stderr if the cache is cold and ``quiet`` is false."""
    if not quiet and cache_is_cold():
        print(MESSAGE, file=sys.stderr, flush=True)
