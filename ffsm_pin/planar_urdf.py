"""Deprecated location of the planar URDF writer, now :mod:`ffsm_pin.robot.writer` (one
writer and one command line for planar and spatial tables); an alias for one release.

``python -m ffsm_pin.planar_urdf TABLE`` still works and reads planar tables only, as before;
use ``python -m ffsm_pin.robot.writer TABLE``.
"""

import sys
import warnings

from .robot.writer import write_urdf
from .robot.writer._xml import escape
from .robot.writer.planar import (
    PlanarBody,
    PlanarChain,
    PlanarLink,
    chain_from_table,
    chain_to_urdf,
)

warnings.warn(
    "ffsm_pin.planar_urdf moved to ffsm_pin.robot.writer (python -m ffsm_pin.robot.writer); "
    "this alias goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)


def main(argv: list[str] | None = None) -> int:
    """The former command line: planar tables only (says on stderr that it is deprecated)."""
    from .robot.writer.__main__ import main as _main

    print(
        "warning: python -m ffsm_pin.planar_urdf is deprecated and goes in the next release; "
        "use python -m ffsm_pin.robot.writer",
        file=sys.stderr,
    )

    return _main(argv, prog="python -m ffsm_pin.planar_urdf", kind="planar")


__all__ = [
    "PlanarBody",
    "PlanarChain",
    "PlanarLink",
    "chain_from_table",
    "chain_to_urdf",
    "escape",
    "main",
    "write_urdf",
]

if __name__ == "__main__":
    raise SystemExit(main())
