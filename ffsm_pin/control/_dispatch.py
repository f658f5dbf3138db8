"""Per-geometry dispatch of a compiled step: a stub that numba compiles as the geometry's own
kernel, chosen by the type of the model's kernel constants (:mod:`.period`'s steps and the
auxiliary system's maps of :mod:`.saturation_kernels` use it)."""

from __future__ import annotations

from typing import Any

from numba import types
from numba.extending import overload

#: The jit options of the steps compiled through :func:`overload_for_geometry`: those of the
#: kernels' ``@njit(cache=True)``. numba keys a cache entry by the function and the argument
#: types, not the options, so both must compile the same code: overload's default
#: ``no_cpython_wrapper=True`` would leave a cache entry that a call from Python (the second
#: process, a test) loads and crashes on.
JIT_OPTIONS: Any = {"nopython": True, "cache": True, "no_cpython_wrapper": False}


def overload_for_geometry(stub: Any, cls: type, impl: Any) -> None:
    """Compile calls of ``stub`` whose first argument is a ``cls`` named tuple as ``impl``.

    Parameters
    ----------
    stub : callable
        The Python stub the compiled code calls.
    cls : type
        The NamedTuple class of the geometry's kernel constants.
    impl : callable
        The geometry's implementation (a plain Python function, compiled with
        :data:`JIT_OPTIONS`).
    """

    @overload(stub, jit_options=JIT_OPTIONS, strict=False)
    def _typed(geo, *args):
        if isinstance(geo, types.BaseNamedTuple) and getattr(geo, "instance_class", None) is cls:
            return impl
        return None  # another geometry's


__all__ = ["JIT_OPTIONS", "overload_for_geometry"]
