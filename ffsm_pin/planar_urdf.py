"""Deprecated location of the planar URDF writer, now :mod:`ffsm_pin.robot.writer` (one
writer and one command line for planar and spatial tables); an alias for one release.

``python -m ffsm_pin.planar_urdf TABLE`` still works and reads planar tables only, as before;
use ``python -m ffsm_pin.robot.writer TABLE``.
"""

import warnings

from .robot.writer import write_urdf
from .robot.writer.__main__ import deprecated_main, moved
from .robot.writer._xml import escape
from .robot.writer.planar import (
    PlanarBody,
    PlanarChain,
    PlanarLink,
    chain_from_table,
    chain_to_urdf,
)

warnings.warn(moved("ffsm_pin.planar_urdf"), DeprecationWarning, stacklevel=2)


def main(argv: list[str] | None = None) -> int:
    """The former command line: planar tables only (says on stderr that it is deprecated)."""
    return deprecated_main("ffsm_pin.planar_urdf", "planar", argv)


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
