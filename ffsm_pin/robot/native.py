"""What C and C++ libraries print: captured at the file-descriptor level, summarised in one line.

Pinocchio's URDF parser (urdfdom, through console_bridge) and the mesh loader (assimp, through
coal) write their diagnostics straight to the process's standard output and error, below
Python's ``sys.stdout``/``sys.stderr``: a user of the command line would see their text
before the package's own one-line ``error:``. :func:`native_output` redirects file descriptors
1 and 2 to a temporary file around such calls (restored in any case) and hands back what was
written; :func:`summary` turns it into one line for an error message or a warning.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import re
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

MAX_SUMMARY = 300  # characters of a summary (the rest is elided)
#: urdfdom's trailer lines ("at line 380 in /project/urdfdom/.../link.cpp") and level prefixes
_WHERE = re.compile(r"^\s*at line \d+ in \S+\s*$")
_LEVEL = re.compile(r"^\s*(Error|Warning|Info|Debug)\s*:\s*", re.IGNORECASE)


@dataclass
class NativeOutput:
    """The text the C/C++ code wrote while :func:`native_output` was active (set on exit)."""

    text: str = ""

    @property
    def has_errors(self) -> bool:
        """Whether a line is an ``Error:`` line (console_bridge's level prefix)."""
        return any(
            (m := _LEVEL.match(line)) and m.group(1).lower() == "error"
            for line in self.text.splitlines()
        )

    def summary(self) -> str:
        """The text as one line (see :func:`summary`)."""
        return summary(self.text)


def summary(text: str, limit: int = MAX_SUMMARY) -> str:
    """One line for what a C/C++ library printed: level prefixes and source locations left out,
    repeated lines once, lines joined by ``"; "``, at most ``limit`` characters.

    Parameters
    ----------
    text : str
        What the library printed.
    limit : int
        Most characters.

    Returns
    -------
    str
        The line.
    """
    parts: list[str] = []
    for line in text.splitlines():
        if not line.strip() or _WHERE.match(line):
            continue
        line = " ".join(_LEVEL.sub("", line).split())
        if line and line not in parts:
            parts.append(line)
    out = "; ".join(parts)
    return out if len(out) <= limit else out[: limit - 3].rstrip() + "..."


def _flush_c_streams() -> None:
    """Flush the C library's stdio buffers (POSIX; a no-op where libc cannot be reached)."""
    if os.name != "posix":
        return
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def native_output() -> Iterator[NativeOutput]:
    """Capture what is written to file descriptors 1 and 2 inside the ``with`` block.

    Yields
    ------
    NativeOutput
        Its ``text`` is filled when the block is left (also when it raises). Python's own
        streams are flushed first, so nothing written before the block is captured.

    Notes
    -----
    The redirection is process-wide: output of other threads during the block is captured
    too. Keep the block to the library call.
    """
    captured = NativeOutput()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, OSError, ValueError):
            stream.flush()
    _flush_c_streams()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no descriptors 1 and 2 (e.g. a detached process): nothing to capture
        yield captured
        return
    with tempfile.TemporaryFile() as sink:
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            yield captured
        finally:
            _flush_c_streams()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            sink.seek(0)
            captured.text = sink.read().decode("utf-8", errors="replace")


@dataclass
class NativeCall:
    """What :func:`native_call` gives back: the value (None on failure), the failure's text
    (a ``RuntimeError``/``ValueError`` the binding raised, on one line) and the captured
    output.

    Attributes
    ----------
    value : Any
        The value, None on failure.
    failure : str or None
        The failure's text, on one line; None on success.
    output : NativeOutput
        The captured output.
    """

    value: Any
    failure: str | None
    output: NativeOutput


def native_call(fn: Callable[..., Any], *args: Any) -> NativeCall:
    """``fn(*args)`` (a C++ binding: Pinocchio's URDF or geometry parsers) with what the C/C++
    code prints captured (:func:`native_output`) and its ``RuntimeError``/``ValueError`` caught
    as text, for the caller's one-line error."""
    value, failure = None, None
    with native_output() as said:
        try:
            value = fn(*args)
        except (RuntimeError, ValueError) as exc:
            failure = " ".join(str(exc).split())
    return NativeCall(value, failure, said)
