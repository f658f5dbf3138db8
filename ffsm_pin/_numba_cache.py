"""numba's settings for the package, made before numba loads: one per-user cache for an
installation wherever it is run from, and a cheaper optimisation level for the first run.

Imported first by ``ffsm_pin/__init__.py``, before anything imports numba:

* ``NUMBA_CACHE_DIR``: a per-user folder instead of ``__pycache__`` beside the sources (which an
  installation may not be able to write). The folder is named by a digest of the package's
  kernel sources (every module that mentions numba): numba checks only the file of the function
  it loads, not the files of the kernels compiled into it, so after an edit of
  ``control/fast_spatial.py`` it would load the control period (``control/period.py``,
  unchanged) with the old kernels inside, silently. A changed source is a new folder and
  everything compiles again; folders not used for :data:`PRUNE_AFTER_DAYS` days are removed.
* Inside that folder, where numba keeps a kernel: numba files the entries of a source file under
  a folder named by the file's absolute directory (``control_<sha1 of /abs/path/control>``), so
  the same package imported from a checkout (``python -m`` from the repository's root puts
  ``./ffsm_pin`` first) and from site-packages, or from two copies, compiled everything once
  per place. :func:`install_locator` puts a locator of the package's own kernels first in
  numba's list: the entries of ``<package>/control/period.py`` are in
  ``<NUMBA_CACHE_DIR>/control/period``, whatever folder the package is in, stamped with a
  digest of the file's bytes (numba 0.68 hashes the bytes too; older versions stamp the
  modification time and size), so every copy with the same bytes shares every entry. It is
  used only in the folder this module chooses (per kernel-source digest: never a stale
  kernel), also when a process inherits it in ``NUMBA_CACHE_DIR`` (a first run's second
  process, a campaign's workers); with a ``NUMBA_CACHE_DIR`` of your own, or numba internals
  this module does not know (another numba version), numba's own locators apply, as before.
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

import functools
import hashlib
import os
import shutil
import time
from pathlib import Path, PurePosixPath
from typing import Any

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


def cache_home() -> Path:
    """``$XDG_CACHE_HOME/ffsm-pin/numba`` (default ``~/.cache/ffsm-pin/numba``): the parent of
    the per-source folders."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "ffsm-pin" / "numba"


def numba_cache_dir(package: Path = PACKAGE) -> str | None:
    """``$XDG_CACHE_HOME/ffsm-pin/numba/<kernel_digest>`` (default ``~/.cache/ffsm-pin/numba/...``);
    touched, and the other sources' folders unused for :data:`PRUNE_AFTER_DAYS` days removed.

    None when the folder cannot be created or written (numba then keeps its default, next to
    the sources).
    """
    parent = cache_home()
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


@functools.cache
def package_path(py_file: str) -> PurePosixPath | None:
    """The path of source file ``py_file`` relative to the package's folder, without its
    suffix (``control/period`` for ``<package>/control/period.py``); None for a file outside
    the package (another package's kernels, or a copy of ffsm_pin this process did not
    import)."""
    try:
        relative = Path(py_file).resolve().relative_to(PACKAGE)
    except (OSError, ValueError):
        return None
    if relative.suffix != ".py":
        return None
    return PurePosixPath(relative.with_suffix("").as_posix())


@functools.cache
def _file_digest(path: str, mtime_ns: int, size: int) -> str:
    """sha256 of the bytes of ``path`` (memoised per modification time and size, as numba's)."""
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def source_digest(path: str) -> str:
    """The source stamp of a package kernel's file: a digest of its bytes, not its modification
    time, so that two copies with the same bytes (a checkout, an installed copy) share their
    cache entries."""
    st = os.stat(path)
    return _file_digest(path, st.st_mtime_ns, st.st_size)


#: the folder this module chose for NUMBA_CACHE_DIR (None: the user's own, or none usable)
CACHE_DIR: str | None = None
#: the package's cache locator, once registered in numba's list (None: numba's own locators)
LOCATOR: type | None = None


def install_locator(caching: Any = None) -> type | None:
    """Register the package's cache locator first in numba's list of locators and return it;
    None, with numba's list unchanged, when numba's private names (``_CacheLocator``,
    ``CacheImpl._locator_classes``, or ``_CacheImpl`` in older numba versions) are not there.

    The locator takes the kernels of the package's own source files when numba's cache folder
    is :data:`CACHE_DIR` (see the module docstring); for every other file, or if anything about
    a file fails, it declines and numba's next locator is asked, as without it.
    """
    try:
        if caching is None:
            from numba.core import caching
        from numba.core import config

        base = caching._CacheLocator
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
        classes = impl._locator_classes
    except (ImportError, AttributeError):
        return None
    if not isinstance(classes, list) or not isinstance(base, type):
        return None
    for cls in classes:
        if getattr(cls, "ffsm_pin_locator", False):  # imported twice (a reload): keep one
            return cls

    class PackageCacheLocator(base):  # type: ignore[misc,valid-type]
        """numba's cache entries of a package kernel: ``<CACHE_DIR>/<module path>``, stamped
        with the digest of the source file's bytes."""

        ffsm_pin_locator = True

        def __init__(self, py_func: Any, py_file: str, module: PurePosixPath) -> None:
            self._py_file = py_file  # numba's warnings name it
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(str(CACHE_DIR), *module.parts)

        def get_cache_path(self) -> str:
            return self._cache_path

        def get_source_stamp(self) -> str:
            return source_digest(self._py_file)

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if CACHE_DIR is None or getattr(config, "CACHE_DIR", None) != CACHE_DIR:
                return None
            module = package_path(py_file)
            if module is None:
                return None
            try:
                self = cls(py_func, py_file, module)
                self.get_source_stamp()
                self.ensure_cache_path()
            except Exception:  # noqa: BLE001 - numba's own locators then apply
                return None
            return self

    classes.insert(0, PackageCacheLocator)
    return PackageCacheLocator


def cache_folder(py_file: Path) -> Path:
    """The folder numba keeps the entries of source file ``py_file`` in: the package's
    locator's, numba's own under ``NUMBA_CACHE_DIR``, or ``__pycache__`` beside the file."""
    cache = os.environ.get("NUMBA_CACHE_DIR")
    if not cache:
        return py_file.parent / "__pycache__"
    module = package_path(str(py_file))
    if LOCATOR is not None and cache == CACHE_DIR and module is not None:
        return Path(cache, *module.parts)
    # numba's folder for a source directory d: <basename(d)>_<sha1(d)>
    folder = str(py_file.resolve().parent)
    return Path(cache) / f"{os.path.basename(folder)}_{hashlib.sha1(folder.encode()).hexdigest()}"


_given = os.environ.get("NUMBA_CACHE_DIR")
if _given is None:
    CACHE_DIR = numba_cache_dir()
    if CACHE_DIR is not None:
        os.environ["NUMBA_CACHE_DIR"] = CACHE_DIR
elif _given == str(cache_home() / kernel_digest()):
    # inherited from a process that imported this package (a first run's second process, a
    # campaign's workers): the same folder, so the same layout, or the entries of one would
    # be lost to the other
    CACHE_DIR = _given
if CACHE_DIR is not None:
    LOCATOR = install_locator()
