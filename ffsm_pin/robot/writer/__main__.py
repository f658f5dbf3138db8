"""``python -m ffsm_pin.robot.writer TABLE [-o URDF]``: read a chain table (TOML), write its
URDF (stdout by default). Bad input (unreadable file, bad TOML, a table the writer rejects) is
one ``error:`` line on stderr and exit status 2."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..._cli import fail
from ...errors import FfsmError
from . import chain_from_table, chain_to_urdf, read_table
from ._xml import tomllib

PROG = "python -m ffsm_pin.robot.writer"


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status. The table's geometry is told apart by
    :func:`~ffsm_pin.robot.writer.table_kind`."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Write the URDF of a free-floating manipulator (planar or spatial) from a "
        "TOML chain table.",
    )
    parser.add_argument("table", type=Path, help="TOML chain table")
    parser.add_argument("-o", "--output", type=Path, help="URDF to write (default: stdout)")
    args = parser.parse_args(argv)
    try:
        table = read_table(args.table)
        chain = chain_from_table(table)
    except (OSError, tomllib.TOMLDecodeError, FfsmError) as exc:
        return fail(f"{args.table}: {exc}")
    text = chain_to_urdf(chain)
    if args.output:
        args.output.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
