"""``python -m ffsm_pin.robot.writer TABLE [-o URDF]``: read a chain table (TOML), write its
URDF (stdout by default). Bad input (unreadable file, bad TOML, a table the writer rejects) is
one ``error:`` line on stderr and exit status 2."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..._cli import fail
from ...errors import FfsmError
from . import KINDS, chain_from_table, chain_to_urdf, read_table
from ._xml import tomllib

PROG = "python -m ffsm_pin.robot.writer"


def main(argv: list[str] | None = None, prog: str = PROG, kind: str | None = None) -> int:
    """Run the command line; returns the exit status. ``kind`` ("planar" or "spatial") reads
    every table as that geometry (the deprecated per-geometry commands); None tells them
    apart (:func:`~ffsm_pin.robot.writer.table_kind`)."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Write the URDF of a free-floating manipulator (planar or spatial) from a "
        "TOML chain table.",
    )
    parser.add_argument("table", type=Path, help="TOML chain table")
    parser.add_argument("-o", "--output", type=Path, help="URDF to write (default: stdout)")
    args = parser.parse_args(argv)
    try:
        table = read_table(args.table)
        chain = chain_from_table(table) if kind is None else KINDS[kind](table)
    except (OSError, tomllib.TOMLDecodeError, FfsmError) as exc:
        return fail(f"{args.table}: {exc}")
    text = chain_to_urdf(chain)
    if args.output:
        args.output.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


def moved(old: str) -> str:
    """The deprecation message of the former module ``old`` (``ffsm_pin.planar_urdf``...)."""
    return f"{old} moved to ffsm_pin.robot.writer ({PROG}); this alias goes in the next release"


def deprecated_main(old: str, kind: str, argv: list[str] | None = None) -> int:
    """The former per-geometry command line ``python -m old``: reads ``kind`` tables only and
    says on stderr that it is deprecated."""
    print(
        f"warning: python -m {old} is deprecated and goes in the next release; use {PROG}",
        file=sys.stderr,
    )
    return main(argv, prog=f"python -m {old}", kind=kind)


if __name__ == "__main__":
    raise SystemExit(main())
