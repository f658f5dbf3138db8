"""The first compilation of a compiled control period on two processes.

A first run (numba's on-disk cache holds nothing for the period yet) spends most of its time
compiling. The period's kernels are separate numba functions, cached one by one, so the work
splits: a second Python process compiles the period's real-valued kernels (and the run's
diagnostics) with the argument types the period passes, while this process compiles the
complex-step kinematic law; the period then finds the former in the cache. The second
process says when the period's kernels are cached and goes on with those a run needs after
the period (the reaction torques, the plant's), while this process compiles the period
itself; the run waits for it (:func:`finish`) before it loads those.
Both processes compile the same source, so nothing changes in what is computed (a run from
an empty cache is bitwise a run from a warm one: ``tests/control/test_first_compile.py``).
When the cache is warm, or a second process cannot be started, nothing happens and the
period compiles (or loads) everything itself. Measured in benchmarks/README.md ("First run").

The compiled period's module (:mod:`.period`) provides ``_compile_real_kernels(*args)`` and
``_compile_run_kernels(*args)``, what the second process runs before and after it says the
period's kernels are ready (the geometry's, chosen by the type of the model's constants).
"""

from __future__ import annotations

import atexit
import importlib
import os
import pickle
import subprocess
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any


def cold(dispatcher: Any) -> bool:
    """True when numba's on-disk cache has no entry at all for ``dispatcher`` (a first run)."""
    try:
        return not os.path.exists(dispatcher._cache._cache_file._index_path)
    except AttributeError:  # internals of another numba version: assume it is cached
        return False


def with_flags(x: Any) -> tuple:
    """(kind, x, extra), recursively through tuples: for an array ``extra`` is its writeable
    flag (numba types a read-only array differently, and pickling drops the flag), for a
    tuple its class when it is a named tuple (which numba types by its class, and which the
    second process must see as such), else None."""
    import numpy as np

    if isinstance(x, np.ndarray):
        return ("array", x, bool(x.flags.writeable))
    if isinstance(x, tuple):
        named = type(x) if hasattr(x, "_fields") else None
        return ("tuple", tuple(with_flags(v) for v in x), named)
    return ("value", x, None)


def restore_flags(item: tuple) -> Any:
    """The inverse of :func:`with_flags`."""
    kind, x, extra = item
    if kind == "array":
        x = x.copy()  # an unpickled array may sit on a read-only buffer
        x.setflags(write=extra)
        return x
    if kind == "tuple":
        items = tuple(restore_flags(v) for v in x)
        return items if extra is None else extra(*items)
    return x


#: Modules whose ``_compile_first_run()`` the second process runs after the period's kernels:
#: kernels a run needs after the controller's (the plant's), registered by their own module
#: (:func:`also_compile`), so that this layer imports nothing above it.
ALSO: list[str] = []


def also_compile(module: str) -> None:
    """Have the second process of a first run also call ``module._compile_first_run()``."""
    if module not in ALSO:
        ALSO.append(module)


#: What the second process writes on its stdout once the period's kernels are in the cache.
READY = b"ready\n"

#: Second processes still compiling a run's kernels (after the period's): see :func:`finish`.
_PENDING: list[subprocess.Popen] = []


def _child_main() -> None:
    """Entry point of the second process: ``(module name, arguments, further modules)`` on
    stdin. It compiles the period's kernels (``_compile_real_kernels``), says :data:`READY`
    on stdout, then compiles the kernels a run needs after the period (``_compile_run_kernels``
    and each further module's ``_compile_first_run``) while the first process compiles the
    period itself."""
    module, args, also = pickle.load(sys.stdin.buffer)
    kernels = importlib.import_module(module)
    args = restore_flags(args)
    kernels._compile_real_kernels(*args)
    sys.stdout.buffer.write(READY)
    sys.stdout.buffer.flush()
    # nothing reads the pipe any more: whatever might be written later goes nowhere (a full
    # pipe would block this process, and the run waiting for it)
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    kernels._compile_run_kernels(*args)
    for name in also:
        importlib.import_module(name)._compile_first_run()


def _wait_ready(child: subprocess.Popen, timeout: float) -> None:
    """Wait until ``child`` says :data:`READY` (or exits, or ``timeout`` [s] passes: then it
    is stopped, and the period compiles what is missing itself)."""
    assert child.stdout is not None  # stdout=PIPE
    reader = threading.Thread(target=child.stdout.readline, daemon=True)
    reader.start()
    reader.join(timeout)
    if reader.is_alive():
        child.kill()
        child.wait()


def finish(timeout: float = 600.0) -> None:
    """Wait for the second processes of first runs still compiling a run's kernels (the
    reaction torques, the plant's), so that the run loads them from the cache instead of
    compiling them again; at most ``timeout`` [s] each, then stopped.
    Called by the run loop before it loads those kernels, and at exit. Does nothing when no
    second process is running (every run but an installation's first)."""
    while _PENDING:
        child = _PENDING.pop()
        try:
            child.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
        if child.stdout is not None:
            child.stdout.close()


atexit.register(finish)


def compile_in_parallel(
    module: str,
    child_args: tuple,
    dispatchers: Sequence[Any],
    compile_here: Callable[[], object],
) -> None:
    """If every dispatcher in ``dispatchers`` is :func:`cold`, start a second process running
    ``module._compile_real_kernels(*child_args)`` (the period's real kernels), then
    ``module._compile_run_kernels(*child_args)`` and ``_compile_first_run()`` of every module
    in :data:`ALSO` (kernels a run needs after the period); call ``compile_here()`` meanwhile
    (its errors are ignored: only the compilation matters, the period reports errors), then
    wait until the second process has the period's kernels in the cache (at most 10 minutes;
    the period compiles what is missing) and return while it compiles the rest:
    :func:`finish` waits for that."""
    if not all(cold(d) for d in dispatchers):
        return
    root = str(Path(__file__).resolve().parents[2])  # the folder that holds ffsm_pin/
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    # this copy of the package, first: `python -c` puts the working folder before PYTHONPATH,
    # and `ffsm-sim` run from a checkout's root with the package installed would otherwise
    # compile the checkout's kernels in the second process
    code = (
        f"import sys; sys.path.insert(0, {root!r}); "
        "from ffsm_pin.control._first_compile import _child_main as f; f()"
    )
    try:
        child = subprocess.Popen(
            [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, env=env,
        )  # fmt: skip
        assert child.stdin is not None  # stdin=PIPE
        child.stdin.write(pickle.dumps((module, with_flags(child_args), list(ALSO))))
        child.stdin.close()
    except OSError:
        return
    try:
        compile_here()
    except Exception:  # noqa: BLE001 - only the compilation matters; period reports errors
        pass
    except BaseException:  # Ctrl-C: do not leave the second process compiling
        child.kill()
        child.wait()
        raise
    try:
        _wait_ready(child, timeout=600)
    except BaseException:  # Ctrl-C while waiting: do not leave the second process compiling
        child.kill()
        child.wait()
        raise
    _PENDING.append(child)  # still compiling the run's other kernels: finish() waits for it


__all__ = [
    "ALSO",
    "READY",
    "also_compile",
    "cold",
    "compile_in_parallel",
    "finish",
    "restore_flags",
    "with_flags",
]
