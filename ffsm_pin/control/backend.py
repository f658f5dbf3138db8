"""Which implementation of a controller runs: its compiled period or its numpy reference."""

from __future__ import annotations

from ..errors import ParameterError, choices_text

#: ``"auto"``: the compiled period when numba is installed, else numpy.
BACKENDS = ("auto", "numba", "numpy")


def numba_available() -> bool:
    """True when the compiled kernels can be imported (numba installed)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def choose_backend(backend: str) -> str:
    """``"numba"`` or ``"numpy"`` for a requested backend (:data:`BACKENDS`).

    Raises
    ------
    ParameterError
        An unknown backend, or ``"numba"`` without numba installed.
    """
    if backend not in BACKENDS:
        raise ParameterError(
            f"unknown backend {backend!r}; valid choices: {choices_text(BACKENDS)}"
        )
    if backend == "numpy":
        return "numpy"
    if numba_available():
        return "numba"
    if backend == "numba":
        raise ParameterError("backend 'numba' needs numba installed (pip install numba)")
    return "numpy"
