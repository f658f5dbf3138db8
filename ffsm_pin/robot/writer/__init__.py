"""Chain table -> URDF, planar and spatial: a free-floating base carrying a serial chain.

A table (TOML file or the equivalent dict) describes the base and the links; the planar
format (revolute-z joints, scalar inertias) is documented in :mod:`.planar`, the spatial one
(any joint axes, full inertia tensors) in :mod:`.spatial`. :func:`chain_from_table` tells them
apart by ``kind = "planar" | "spatial"`` when the table says it, else by the base inertia (a
number: planar; six numbers: spatial). One command line for both::

    python -m ffsm_pin.robot.writer TABLE.toml [-o ROBOT.urdf]    # default: stdout

The shipped robots in ``urdf/`` are written this way (their tables sit beside them).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ...errors import ParameterError
from . import planar, spatial
from ._xml import tomllib
from .planar import PlanarBody, PlanarChain, PlanarLink
from .spatial import SpatialBody, SpatialChain, SpatialLink

#: The geometries a table can describe, and their readers.
KINDS: dict[str, Callable[[dict], PlanarChain | SpatialChain]] = {
    "planar": planar.chain_from_table,
    "spatial": spatial.chain_from_table,
}


def table_kind(table: dict) -> str:
    """``"planar"`` or ``"spatial"``: the table's ``kind``, else read off the base inertia."""
    kind = table.get("kind") if isinstance(table, dict) else None
    if kind is not None:
        if kind not in KINDS:
            raise ParameterError(f"kind {kind!r} unknown; valid choices: 'planar', 'spatial'")
        return kind
    base = table.get("base") if isinstance(table, dict) else None
    inertia = base.get("inertia") if isinstance(base, dict) else None
    if isinstance(inertia, (int, float)) and not isinstance(inertia, bool):
        return "planar"
    if isinstance(inertia, (list, tuple)):
        return "spatial"
    raise ParameterError(
        "robot table: cannot tell planar from spatial: set kind = 'planar' or 'spatial', or "
        "give base.inertia (a number: planar I_zz; six numbers ixx iyy izz ixy ixz iyz: spatial)"
    )


def read_table(path: str | Path) -> dict:
    """The dict form of a TOML chain table file."""
    return tomllib.loads(Path(path).read_text())


def chain_from_table(table: dict) -> PlanarChain | SpatialChain:
    """The chain a table describes (:func:`table_kind` picks the geometry)."""
    return KINDS[table_kind(table)](table)


def chain_to_urdf(chain: PlanarChain | SpatialChain) -> str:
    """The URDF text of a planar or spatial chain."""
    if isinstance(chain, PlanarChain):
        return planar.chain_to_urdf(chain)
    if isinstance(chain, SpatialChain):
        return spatial.chain_to_urdf(chain)
    raise ParameterError(f"expected a PlanarChain or SpatialChain, got {type(chain).__name__}")


def write_urdf(chain: PlanarChain | SpatialChain, path: str | Path) -> Path:
    """Write the URDF of ``chain`` to ``path`` and return the path.

    Parameters
    ----------
    chain : PlanarChain or SpatialChain
        The robot.
    path : str or Path
        The file written.

    Returns
    -------
    Path
        The path.
    """
    path = Path(path)
    path.write_text(chain_to_urdf(chain))
    return path


__all__ = [
    "KINDS",
    "PlanarBody",
    "PlanarChain",
    "PlanarLink",
    "SpatialBody",
    "SpatialChain",
    "SpatialLink",
    "chain_from_table",
    "chain_to_urdf",
    "read_table",
    "table_kind",
    "write_urdf",
]
