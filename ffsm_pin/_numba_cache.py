"""numba's settings for the package, made before numba loads: one per-user cache for an
installation wherever it is run from, and a cheaper optimisation level for the first run.

Imported first by ``ffsm_pin/__init__.py``, before anything imports numba:

* ``NUMBA_CACHE_DIR``: numba's cache index is keyed by the source file's path, so the source
  tree and an installed copy, or runs from different folders, would otherwise compile the same
  kernels again. The folder is named by a digest of the package's kernel sources (every module
  that mentions numba): numba checks only the file of the function it loads, not the files of
  the kernels compiled into it, so after an edit of ``control/fast_spatial.py`` it would load
  the control period (``control/period.py``, unchanged) with the old kernels inside, silently.
  A changed source is a new folder and everything compiles again; folders not used for
  :data:`PRUNE_AFTER_DAYS` days are removed.
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

import hashlib
import os
import shutil
import time
from pathlib import Path

#: the package's folder, whose kernel sources name the cache folder
PACKAGE = Path(__file__).resolve().parent
#: cache folders of other sources (other versions, edited trees) unused this long are removed
PRUNE_AFTER_DAYS = 30


def kernel_digest(package: Path = PACKAGE) -> str:
    """A digest of the package's kernel sources: the path and bytes of every ``.py`` file under
    ``package`` that mentions numba (the kernels, and the modules that compile or call them),
    in path order. 16 hex digits."""
    h = hashlib.sha1()
    for path in sorted(package.rglob("*.py")):
        data = path.read_bytes()
        if b"numba" in data:
            h.update(path.relative_to(package).as_posix().encode() + b"\0" + data + b"\0")
    return h.hexdigest()[:16]


def prune(folder: Path, keep: str, days: float = PRUNE_AFTER_DAYS) -> None:
    """Remove the entries of ``folder`` other than ``keep`` not modified for ``days`` days (the
    caches of other sources; a folder in use is touched by :func:`numba_cache_dir`)."""
    limit = time.time() - days * 86400.0
    for entry in folder.iterdir():
        try:
            if entry.name != keep and entry.stat().st_mtime < limit:
                if entry.is_dir():
                    shutil.rmtree(entry, ignore_errors=True)
                else:
                    entry.unlink()
        except OSError:  # another process pruned it, or it is not ours to remove
            pass


def numba_cache_dir(package: Path = PACKAGE) -> str | None:
    """``$XDG_CACHE_HOME/ffsm-pin/numba/<kernel_digest>`` (default ``~/.cache/ffsm-pin/numba/...``);
    touched, and the other sources' folders unused for :data:`PRUNE_AFTER_DAYS` days removed.

    None when the folder cannot be created or written (numba then keeps its default, next to
    the sources).
    """
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    parent = Path(base) / "ffsm-pin" / "numba"
    digest = kernel_digest(package)
    folder = parent / digest
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)  # in use: not pruned by another source's run
        prune(parent, keep=digest)
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
