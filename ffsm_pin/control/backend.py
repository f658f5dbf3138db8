"""Which implementation of a controller runs: its compiled period or its numpy reference.

numba is a dependency of the package (``import ffsm_pin`` loads it, :mod:`ffsm_pin._numba_cache`),
so the compiled period is always there; the numpy reference is the readable path a user may
ask for (``backend="numpy"``), tested against the compiled one.
"""

from __future__ import annotations

from ..errors import ParameterError, choices_text

#: ``"auto"``: the controller's default, the compiled period; ``"numba"``: the compiled
#: period; ``"numpy"``: the readable reference.
BACKENDS = ("auto", "numba", "numpy")


def numba_available() -> bool:
    """Always True since 0.2.0: numba is a dependency, imported by ``import ffsm_pin``.

    Kept for its callers (``compiled=numba_available()``); before 0.2.0 it said whether numba
    could be imported.
    """
    return True


def choose_backend(backend: str) -> str:
    """``"numba"`` or ``"numpy"`` for a requested backend (:data:`BACKENDS`): ``"auto"`` is the
    compiled period.

    Raises
    ------
    ParameterError
        An unknown backend.
    """
    if backend not in BACKENDS:
        raise ParameterError(
            f"unknown backend {backend!r}; valid choices: {choices_text(BACKENDS)}"
        )
    return "numpy" if backend == "numpy" else "numba"
