"""Deprecated location of the spatial URDF writer, now :mod:`ffsm_pin.robot.writer` (one
writer and one command line for planar and spatial tables); an alias for one release.

``python -m ffsm_pin.spatial_urdf TABLE`` still works and reads spatial tables only, as before;
use ``python -m ffsm_pin.robot.writer TABLE``.
"""

import warnings

from .robot.writer import write_urdf
from .robot.writer.__main__ import deprecated_main, moved
from .robot.writer._xml import escape
from .robot.writer.spatial import (
    SpatialBody,
    SpatialChain,
    SpatialLink,
    chain_from_table,
    chain_to_urdf,
    inertial_xml,
)

warnings.warn(moved("ffsm_pin.spatial_urdf"), DeprecationWarning, stacklevel=2)


def main(argv: list[str] | None = None) -> int:
    """The former command line: spatial tables only (says on stderr that it is deprecated)."""
    return deprecated_main("ffsm_pin.spatial_urdf", "spatial", argv)


__all__ = [
    "SpatialBody",
    "SpatialChain",
    "SpatialLink",
    "chain_from_table",
    "chain_to_urdf",
    "escape",
    "inertial_xml",
    "main",
    "write_urdf",
]

if __name__ == "__main__":
    raise SystemExit(main())
