"""One per-user numba cache for an installation, wherever it is run from.

Imported first by ``ffsm_pin/__init__.py``, before anything imports numba: numba's cache index
is keyed by the source file's path, so the source tree and an installed copy, or runs from
different folders, would otherwise compile the same kernels again. The user's own
``NUMBA_CACHE_DIR`` wins.
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


if "NUMBA_CACHE_DIR" not in os.environ:
    _cache = numba_cache_dir()
    if _cache is not None:
        os.environ["NUMBA_CACHE_DIR"] = _cache
