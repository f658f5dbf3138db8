"""Say on stderr when the controller kernels are about to be compiled (a cold numba cache)."""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import ffsm_pin

MESSAGE = "compiling the controller kernels (first run only, about 15-30 s)"


def cache_is_cold() -> bool:
    """True when no numba index (``*.nbi``) of this installation's controller kernels exists.

    Looks in ``NUMBA_CACHE_DIR`` (set per user by :mod:`ffsm_pin`) under the folder numba
    derives from the source path, or in ``__pycache__`` next to the sources.
    """
    control = Path(ffsm_pin.__file__).resolve().parent / "control"
    places = [control / "__pycache__"]
    cache = os.environ.get("NUMBA_CACHE_DIR")
    if cache:  # numba then uses this folder only
        places = []
        # numba's folder for a source directory d: <basename(d)>_<sha1(d)>
        digest = hashlib.sha1(str(control).encode()).hexdigest()
        places.append(Path(cache) / f"control_{digest}")
    return not any(p.is_dir() and any(p.glob("fast*.nbi")) for p in places)


def note_compilation(quiet: bool) -> None:
    """Print :data:`MESSAGE` on stderr if the cache is cold and ``quiet`` is false."""
    if not quiet and cache_is_cold():
        print(MESSAGE, file=sys.stderr, flush=True)
