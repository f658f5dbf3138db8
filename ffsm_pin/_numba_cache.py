"""numba's settings for the package, made before numba loads: one per-user cache for an
installation wherever it is run from, and a cheaper optimisation level for the first run.

Imported first by ``ffsm_pin/__init__.py``, before anything imports numba:

* ``NUMBA_CACHE_DIR``: numba's cache index is keyed by the source file's path, so the source
  tree and an installed copy, or runs from different folders, would otherwise compile the same
  kernels again.
* ``NUMBA_OPT = 2`` and ``NUMBA_LOOP_VECTORIZE = 0`` (numba's defaults are 3 and 1): LLVM's
  level-3 passes and its loop vectoriser cost about a fifth of a first run's compilation
  (case 1 27.6 -> 22.2 s, spatial 31.4 -> 27.8 s) and buy nothing on the kernels' arrays of a
  few entries (per step 62.0 -> 60.6 us planar, 169.7 -> 168.5 us spatial). Neither changes a
  result: without fast-math LLVM may not reorder floating-point operations at any level, and
  the built-in cases are bitwise equal (benchmarks/README.md, "First run").

A value the user has set wins, for each of the three; when numba was imported before
``ffsm_pin``, its settings are already fixed and these have no effect.
"""

from __future__ import annotations

import os
from pathlib import Path


def numba_cache_dir() -> str | None:
    """``$XDG_CACHE_HOME/ffsm-pin/numba`` (default ``~/.cache/ffsm-pin/numba``).

    None when the folder cannot be created or written (numba then keeps its default, next to
    the sources).
    """
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = Path(base) / "ffsm-pin" / "numba"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return str(folder) if os.access(folder, os.W_OK) else None


#: numba settings the package chooses when the user has not (see the module docstring)
SETTINGS = {"NUMBA_OPT": "2", "NUMBA_LOOP_VECTORIZE": "0"}
for _key, _value in SETTINGS.items():
    os.environ.setdefault(_key, _value)

if "NUMBA_CACHE_DIR" not in os.environ:
    _cache = numba_cache_dir()
    if _cache is not None:
        os.environ["NUMBA_CACHE_DIR"] = _cache
