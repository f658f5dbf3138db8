"""Pieces shared by the command lines (``python -m ffsm_pin.sim``, ``python -m ffsm_pin.sweep``):
an argparse parser that raises instead of exiting, argument types, and the one-line error."""

from __future__ import annotations

import argparse
import math
import sys

EXIT_BAD_INPUT = 2  # bad input: one ``error: ...`` line on stderr, nothing run


class UsageError(Exception):
    """A bad command line (argparse's error(), raised instead of exiting)."""


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors raise :class:`UsageError`, so that the caller prints
    them as one ``error:`` line."""

    def error(self, message: str):  # noqa: D102 - argparse API
        raise UsageError(message)


def command_parser(module: str, description: str, epilog: str) -> Parser:
    """The parser of ``python -m <module>``: its description, then the options, then the epilog
    as written (line breaks kept).

    Parameters
    ----------
    module : str
        The package the command runs (``ffsm_pin.sim``, ``ffsm_pin.sweep``).
    description : str
        What the command does.
    epilog : str
        The text after the options (exit statuses, output files).

    Returns
    -------
    Parser
        The parser, without arguments yet.
    """
    return Parser(
        prog=f"python -m {module}",
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def fail(message: str) -> int:
    """Print ``message`` as one ``error:`` line on stderr; return the bad-input exit status."""
    print(f"error: {' '.join(message.split())}", file=sys.stderr)
    return EXIT_BAD_INPUT
