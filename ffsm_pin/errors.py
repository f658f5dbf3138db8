"""One exception hierarchy for everything ffsm-pin refuses.

Every error names the offending item and, where there is a finite set of valid
choices, lists them. Subclasses also derive from the matching builtin
(`ValueError`, `FileNotFoundError`, `KeyError`) so generic handlers still work.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from pathlib import Path


class FfsmError(Exception):
    """Base class of every error raised on purpose by ffsm-pin."""


class RobotFileError(FfsmError, FileNotFoundError):
    """A robot description file does not exist or cannot be read."""


class UrdfError(FfsmError, ValueError):
    """A URDF is malformed or describes a robot the model does not support."""


class UnsupportedJointError(UrdfError):
    """A joint type, axis or placement outside planar revolute-z chains."""


class InertiaError(UrdfError):
    """A body with non-positive mass or rotational inertia."""


class FrameNotFoundError(FfsmError, ValueError):
    """A frame name that is not in the robot model."""


class ParameterError(FfsmError, ValueError):
    """A gain, funnel, parameter vector or option with a bad value or shape."""


class InfeasibleTaskError(FfsmError, ValueError):
    """The robot cannot serve the requested task plus attitude regulation."""


class ScenarioError(FfsmError, ValueError):
    """A scenario file that is missing, malformed or inconsistent with its robot."""


class StorageError(FfsmError, ValueError):
    """A run whose recording would not fit in the memory or on the disk there is."""


class OutputError(FfsmError, OSError):
    """A run's or a campaign's file could not be written (full disk, file-size limit,
    permissions); the message names the file. What the folder held before is kept."""


class SimulationError(FfsmError, RuntimeError):
    """A run that had to stop: funnel left, singular arm, non-finite numbers.

    Parameters
    ----------
    message : str
        The error's text.
    time, cause, funnel : float, str, str or None
        The attributes below.

    Attributes
    ----------
    time : float
        Simulated time [s] at which the run stopped.
    cause : str
        Short machine-readable cause (``"funnel"``, ``"singular"``, ``"nonfinite"``,
        ``"estimate"``).
    funnel : str or None
        For ``cause == "funnel"``: which funnel was left, ``"b"`` (attitude, Eq. 16) or ``"z"``
        (end effector, Eq. 17); otherwise None.
    """

    def __init__(self, message: str, *, time: float, cause: str, funnel: str | None = None):
        super().__init__(message)
        self.time = float(time)
        self.cause = cause
        self.funnel = funnel


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """Return ``" (did you mean 'x'?)"`` for the closest choice, or ``""``.

    Parameters
    ----------
    name : str
        The unknown name.
    choices : iterable of str
        The valid names.

    Returns
    -------
    str
        The hint, or ``""`` when no choice is close.
    """
    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.5)
    return f" (did you mean '{close[0]}'?)" if close else ""


def choices_text(choices: Iterable[str]) -> str:
    """Format valid choices for an error message."""
    return ", ".join(repr(c) for c in choices)


def check_keys(table: Iterable[str], valid: Sequence[str], what: str) -> None:
    """:class:`ParameterError` for the first key of ``table`` that is not ``valid``:
    ``"<what>: unknown key 'x' (did you mean 'y'?); valid keys: ..."``.

    Parameters
    ----------
    table : iterable of str
        The keys given.
    valid : sequence of str
        The valid keys.
    what : str
        What the table is, for the message (e.g. ``"controller.params"``).
    """
    for key in table:
        if key not in valid:
            raise ParameterError(
                f"{what}: unknown key {key!r}{did_you_mean(key, valid)}; "
                f"valid keys: {choices_text(valid)}"
            )


def expected_count(n: int) -> str:
    """The lengths a value may have when a single number is broadcast: ``"1 or 3"``, and ``"1"``
    when the full length is 1 itself."""
    return "1" if n == 1 else f"1 or {n}"


def not_a_file(path: Path) -> str:
    """Why ``path`` is no readable file, for a message: ``"not found"``, ``"is a folder, not a
    file"`` or ``"is not a regular file"`` (a FIFO, a device, a socket: never opened)."""
    if path.is_dir():
        return "is a folder, not a file"
    if path.exists():
        return "is not a regular file"
    return "not found"


class ControllerLoadError(ScenarioError):
    """A controller type that cannot be found, imported or built (bad input, exit 2)."""
