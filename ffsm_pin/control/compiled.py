"""The controller kit: a controller with a readable numpy step and compiled kernels.

:class:`CompiledController` is the base of the package's controllers (the paper's law,
:class:`~.controller.CoordinatedController`, and the baselines) and of any controller written
the same way. It owns what every such controller needs besides its law:

* the backend (:data:`~.backend.BACKENDS`): ``"auto"`` and ``"numba"`` run the compiled step,
  ``"numpy"`` the readable reference (a subclass may refine the choice: :meth:`choose`);
* the warm-up: before the run's clock starts, the compiled step runs once at the initial
  measurement, with the types a run passes, on copies of the controller's state (nothing it
  advances moves, no warning is shown, a stop the law would raise is left to the run), so
  that numba compiles (or loads from its cache) every kernel then and never inside the run;
* the step binding: ``step`` is the compiled step or the numpy one, bound once.

A subclass gives its numpy step (:meth:`step_numpy`), its compiled step
(:meth:`step_compiled`: its kernels called on its named bundles, typically NamedTuples made
once by :meth:`prepare_kernels`), and keeps what a step advances in :attr:`state`, a NamedTuple
of arrays (``()`` when it has none). It calls :meth:`bind_backend` last in its constructor.
docs/controllers.md ("Adding a built-in controller") shows the whole pattern, and
``tests/control/kit_pd.py`` is a small complete example.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

import numpy as np

from .._arrays import read_only_view
from ..errors import ParameterError, SimulationError
from .backend import choose_backend
from .interface import Measurement


def copied(state: Any) -> Any:
    """A copy of ``state``: arrays copied (layout and writeable flag kept, so the copy types
    as the original in a compiled kernel), named tuples and tuples item by item, anything
    else as it is."""
    if isinstance(state, np.ndarray):
        out = state.copy()
        out.flags.writeable = state.flags.writeable
        return out
    if isinstance(state, tuple):
        items = [copied(x) for x in state]
        return type(state)(*items) if hasattr(state, "_fields") else tuple(items)
    return state


def kernel_measurement(meas: Measurement, m3: int) -> tuple:
    """The fields of ``meas`` with the types a compiled kernel is warmed up and run with, as a
    plain tuple (``Measurement(*fields)`` names them again, in a kernel or in Python): a planar
    q_b as a float, the true M and C w (known-model controllers) read-only as the sensor's
    model hands them out (numba types a read-only array apart from a writeable one).

    A kernel called every period may take its bundles' fields as plain tuples and name them on
    entry: numba types a plain tuple from Python at a fraction of a named one's cost (a named
    tuple's class and field names are part of its type); the package's periods do.

    Parameters
    ----------
    meas : Measurement
        The measurement.
    m3 : int
        Attitude coordinates: 1 planar, 3 spatial.

    Returns
    -------
    tuple
        Its fields (t, q_b, q_m, w, z_e, z_e_dot, M, h).
    """
    q_b = float(meas.q_b) if m3 == 1 else meas.q_b
    M = None if meas.M is None else read_only_view(meas.M)
    h = None if meas.h is None else read_only_view(meas.h)
    return (meas.t, q_b, meas.q_m, meas.w, meas.z_e, meas.z_e_dot, M, h)


def state_field(name: str, doc: str) -> Any:
    """A property that reads and writes the field ``name`` of the controller's
    :attr:`~CompiledController.state` (a NamedTuple): ``theta_d = state_field("theta_d", ...)``
    keeps ``controller.theta_d`` the array the compiled kernels advance in place, and an
    assignment (the numpy step's) replaces it in the state.

    Parameters
    ----------
    name : str
        The field of the controller's state.
    doc : str
        The property's docstring.

    Returns
    -------
    property
        Reads and writes that field.
    """

    def get(self: Any) -> Any:
        return getattr(self.state, name)

    def put(self: Any, value: Any) -> None:
        self.state = self.state._replace(**{name: value})

    return property(get, put, doc=doc)


#: False inside :func:`no_warm_up`: controllers built then skip the warm-up.
_WARM_UP: ContextVar[bool] = ContextVar("ffsm_pin_warm_up", default=True)


@contextmanager
def no_warm_up() -> Iterator[None]:
    """Build controllers without warming their compiled step up (nothing is compiled).

    For a caller that builds a run but never steps it (``--check``): a controller built
    inside takes its backend and bundles as usual, and its first compiled step, if one ever
    runs, compiles (or loads from the cache) then.
    """
    token = _WARM_UP.set(False)
    try:
        yield
    finally:
        _WARM_UP.reset(token)


class CompiledController:
    """Base of a controller with a numpy step and a compiled one (module docstring).

    Attributes
    ----------
    backend : str
        ``"numba"`` (the compiled step) or ``"numpy"`` (the readable reference), chosen by
        :meth:`bind_backend`; assigning it switches the step (on ``"numba"`` the kernels'
        bundles are made first if they are not yet; nothing is warmed up then).
    state : Any
        What a step advances, a NamedTuple of arrays (the compiled kernels advance them in
        place); the warm-up runs on a copy. ``()`` when the controller keeps no state.
    """

    _backend = "numpy"
    _kernels_ready = False
    state: Any = ()

    @property
    def backend(self) -> str:
        """``"numba"`` or ``"numpy"``: which step runs (see the class's attributes)."""
        return self._backend

    @backend.setter
    def backend(self, value: str) -> None:
        if value not in ("numba", "numpy"):
            raise ParameterError(f"backend {value!r}: the step runs on 'numba' or 'numpy'")
        if value == "numba" and not self._kernels_ready:
            self.prepare_kernels()
            self._kernels_ready = True
        self._backend = value
        self.bind()

    # ------------------------------------------------------------------ for a subclass
    def step_numpy(self, meas: Measurement, *args: Any) -> Any:
        """The period by the readable numpy reference."""
        raise NotImplementedError

    def step_compiled(self, meas: Measurement, *args: Any) -> Any:
        """The period by the compiled kernels."""
        raise NotImplementedError

    def prepare_kernels(self) -> None:
        """Make the compiled kernels' constant bundles (called once, before the warm-up, only
        on the compiled backend). Nothing by default."""

    def choose(self, backend: str) -> str:
        """``"numba"`` or ``"numpy"`` for a requested backend (:func:`~.backend.choose_backend`:
        ``"auto"`` is the compiled step). A subclass may refine it."""
        return choose_backend(backend)

    def warm_up_call(self, meas: Measurement, *args: Any) -> None:
        """What the warm-up runs (on copies of :attr:`state`): the compiled step at ``meas``.
        A subclass whose compiled step does more than call its kernels (bookkeeping) may
        call the kernels alone here."""
        self.step_compiled(meas, *args)

    # ------------------------------------------------------------------ the kit
    def bind_backend(self, backend: str, initial: Measurement, *args: Any) -> str:
        """Choose the backend, and on the compiled one make the kernels' bundles and warm them
        up at ``initial`` (the run's exact measurement at t = 0; ``args`` the further arguments
        of a step); then bind :meth:`step`. Returns the backend. The last call of a
        subclass's constructor.

        Parameters
        ----------
        backend : str
            The backend asked for ("numba", "numpy" or "auto", see ``choose``).
        initial : Measurement
            The run's exact measurement at t = 0.

        Returns
        -------
        str
            The backend chosen.
        """
        self.backend = self.choose(backend)  # (the kernels' bundles made on "numba"; bound)
        if self.backend == "numba" and _WARM_UP.get():
            self.warm_up(initial, *args)
        return self.backend

    def warm_up(self, meas: Measurement, *args: Any) -> None:
        """Compile (or load from numba's cache) the compiled step's kernels now, before the
        run's clock: :meth:`warm_up_call` on a copy of :attr:`state`, restored afterwards;
        warnings are not shown and a stop (:class:`~ffsm_pin.errors.SimulationError`) is left
        to the run, whose first period meets it again."""
        saved = self.state
        self.state = copied(saved)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self.warm_up_call(meas, *args)
        except SimulationError:
            pass
        finally:
            self.state = saved

    def bind(self) -> None:
        """Bind :meth:`step` to the chosen backend's step (an instance attribute: a call skips
        the choice)."""
        self.step = self.step_compiled if self.backend == "numba" else self.step_numpy  # type: ignore[method-assign]

    def step(self, meas: Measurement, *args: Any) -> Any:
        """The period on the chosen backend (bound per instance by :meth:`bind`)."""
        if self.backend == "numba":
            return self.step_compiled(meas, *args)
        return self.step_numpy(meas, *args)


__all__ = ["CompiledController", "copied", "kernel_measurement", "no_warm_up", "state_field"]
