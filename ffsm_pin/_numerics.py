"""What a run's numbers were computed with: the versions of the libraries that compute them
and the BLAS kernels this process uses.

OpenBLAS picks its kernels for the CPU when it is loaded (``OPENBLAS_CORETYPE`` overrides the
choice), and kernels of two CPUs round differently: the same code gives the same verdicts and
numbers that part by each run's rounding envelope (docs/REPRODUCTION.md, "Reproducing the
shipped numbers on another CPU"). A run's ``summary.json`` and a campaign's rows carry both
strings (:func:`blas`, :func:`versions`), so a difference between two machines' results can be
traced to its cause.
"""

from __future__ import annotations

import functools
import platform

__all__ = ["blas", "versions"]


@functools.lru_cache(maxsize=1)
def versions() -> str:
    """The versions of ffsm-pin and of the libraries a run's arithmetic goes through.

    Returns
    -------
    str
        ``"ffsm-pin X, python X, numpy X, scipy X, pinocchio X, numba X"``.
    """
    import numba
    import numpy
    import pinocchio
    import scipy

    from . import __version__

    parts = [
        ("ffsm-pin", __version__), ("python", platform.python_version()),
        ("numpy", numpy.__version__), ("scipy", scipy.__version__),
        ("pinocchio", pinocchio.__version__), ("numba", numba.__version__),
    ]  # fmt: skip
    return ", ".join(f"{name} {version}" for name, version in parts)


def blas() -> str:
    """The BLAS libraries loaded in this process with their versions and the kernels they use
    (``threadpoolctl``), e.g. ``"openblas 0.3.31 Haswell"``; several separated by ``"; "``
    (numpy's and scipy's each bring one: numba's compiled matrix products use scipy's).

    Call it after the work: a library that is not loaded yet is not listed. Each call reads
    the loaded libraries again (about a millisecond).

    Returns
    -------
    str
        One entry per BLAS library, ``"none found"`` when there is none.
    """
    from threadpoolctl import threadpool_info

    keys = ("internal_api", "version", "architecture")  # e.g. openblas 0.3.31 Haswell
    found = {
        " ".join(str(lib[k]) for k in keys if lib.get(k))
        for lib in threadpool_info()
        if lib.get("user_api") == "blas"
    }
    return "; ".join(sorted(found)) or "none found"
