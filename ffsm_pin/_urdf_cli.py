"""The command line shared by the chain-table -> URDF generators (planar and spatial)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ._cli import fail
from .errors import FfsmError

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib  # type: ignore[no-redef]


def table_to_urdf_main(
    prog: str,
    description: str,
    chain_from_table: Callable[[dict], Any],
    chain_to_urdf: Callable[[Any], str],
    argv: list[str] | None = None,
) -> int:
    """``prog TABLE [-o URDF]``: read a TOML chain table, write its URDF (stdout by default).

    Bad input (unreadable file, bad TOML, a table the generator rejects) is one ``error:`` line
    on stderr and exit status 2.
    """
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("table", type=Path, help="TOML parameter table")
    parser.add_argument("-o", "--output", type=Path, help="URDF to write (default: stdout)")
    args = parser.parse_args(argv)
    try:
        chain = chain_from_table(tomllib.loads(args.table.read_text()))
    except (OSError, tomllib.TOMLDecodeError, FfsmError) as exc:
        return fail(f"{args.table}: {exc}")
    text = chain_to_urdf(chain)
    if args.output:
        args.output.write_text(text)
    else:
        sys.stdout.write(text)
    return 0
