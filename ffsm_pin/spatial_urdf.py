"""Write the URDF of a spatial free-floating serial manipulator from a small table.

The spatial counterpart of :mod:`ffsm_pin.planar_urdf`. The table is a TOML file (or the
equivalent dict)::

    name = "spatial3"
    end_effector = "ee"                    # optional, default "ee"

    [base]
    mass = 200.0                           # [kg]
    inertia = [40.0, 40.0, 40.0, 0.0, 0.0, 0.0]   # ixx iyy izz ixy ixz iyz about the CoM [kg m^2]
    com = [0.0, 0.0, 0.0]                  # CoM in the base frame [m] (optional)
    size = [1.0, 1.0, 1.0]                 # visual box [m] (optional)

    [[links]]                              # one table per link, base outwards
    mass = 5.0
    inertia = [0.2, 0.2, 0.05, 0.01, 0.0, 0.0]
    com = [0.0, 0.05, 0.2]                 # link CoM in the link (= joint) frame [m]
    origin_xyz = [0.5, 0.0, 0.5]           # this link's joint in the parent frame [m]
    origin_rpy = [0.0, 0.3, 0.0]           # its rotation (URDF roll-pitch-yaw) [rad] (optional)
    axis = [0.0, 0.0, 1.0]                 # joint axis in the joint frame (optional, +z)

    [ee]                                   # end-effector frame in the last link (optional)
    xyz = [0.0, 0.0, 0.4]
    rpy = [0.0, 0.0, 0.0]

Every joint is revolute; the end-effector frame is a fixed child of the last link. Inertias
are full 3x3 tensors about the CoM, in the link frame (URDF ``<inertia>``, no rotated
inertial frame).

Command line::

    python -m ffsm_pin.spatial_urdf table.toml -o robot.urdf
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ._urdf_cli import table_to_urdf_main
from .errors import ParameterError
from .planar_urdf import escape

_INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")  # table order (as the scenario files)


def _vec(x, n: int, key: str) -> tuple[float, ...]:
    try:
        values = tuple(_num(v, key) for v in x)
    except TypeError:
        raise ParameterError(f"{key}: expected a {n}-vector, got {x!r}") from None
    if len(values) != n:
        raise ParameterError(f"{key}: expected a {n}-vector, got {list(values)}")
    return values


def _num(value, key: str) -> float:
    if isinstance(value, bool):
        raise ParameterError(f"{key}: expected a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{key}: expected a number, got {value!r}") from None


@dataclass(frozen=True)
class SpatialBody:
    """Mass properties of one rigid body: mass [kg], inertia (ixx iyy izz ixy ixz iyz) about
    the CoM in the body frame [kg m^2], CoM in the body frame [m]."""

    mass: float
    inertia: tuple[float, float, float, float, float, float]
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", _num(self.mass, "mass"))
        object.__setattr__(self, "inertia", _vec(self.inertia, 6, "inertia"))
        object.__setattr__(self, "com", _vec(self.com, 3, "com"))


@dataclass(frozen=True)
class SpatialLink(SpatialBody):
    """A link: its mass properties and its joint (placement in the parent, axis)."""

    origin_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    origin_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "origin_xyz", _vec(self.origin_xyz, 3, "origin_xyz"))
        object.__setattr__(self, "origin_rpy", _vec(self.origin_rpy, 3, "origin_rpy"))
        axis = _vec(self.axis, 3, "axis")
        if sum(a * a for a in axis) == 0.0:
            raise ParameterError("axis: a joint axis must not be zero")
        object.__setattr__(self, "axis", axis)


@dataclass(frozen=True)
class SpatialChain:
    """A floating base (satellite) carrying a serial chain of revolute links."""

    name: str
    base: SpatialBody
    links: tuple[SpatialLink, ...]
    end_effector: str = "ee"
    ee_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ee_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_size: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "ee_xyz", _vec(self.ee_xyz, 3, "ee.xyz"))
        object.__setattr__(self, "ee_rpy", _vec(self.ee_rpy, 3, "ee.rpy"))
        object.__setattr__(self, "base_size", _vec(self.base_size, 3, "base.size"))
        if not self.links:
            raise ParameterError(f"robot {self.name!r}: at least one link is needed")
        for i, body in enumerate((self.base, *self.links)):
            what = "base" if i == 0 else f"links[{i}]"
            if not body.mass > 0:
                raise ParameterError(f"{what}: mass must be > 0, got {body.mass}")


def chain_from_table(table: dict) -> SpatialChain:
    """Build a :class:`SpatialChain` from the dict form of the TOML table."""
    base = _get(table, "base", "robot table")
    links = _get(table, "links", "robot table")
    ee = table.get("ee", {})
    return SpatialChain(
        name=str(table.get("name", "spatial_ffsm")),
        base=SpatialBody(
            mass=_num(_get(base, "mass", "base"), "base.mass"),
            inertia=_vec(_get(base, "inertia", "base"), 6, "base.inertia"),
            com=_vec(base.get("com", (0.0, 0.0, 0.0)), 3, "base.com"),
        ),
        base_size=_vec(base.get("size", (1.0, 1.0, 1.0)), 3, "base.size"),
        end_effector=str(table.get("end_effector", "ee")),
        ee_xyz=_vec(ee.get("xyz", (0.0, 0.0, 0.0)), 3, "ee.xyz"),
        ee_rpy=_vec(ee.get("rpy", (0.0, 0.0, 0.0)), 3, "ee.rpy"),
        links=tuple(_link(link, i) for i, link in enumerate(links, start=1)),
    )


def _link(link: dict, i: int) -> SpatialLink:
    where = f"links[{i}]"
    return SpatialLink(
        mass=_num(_get(link, "mass", where), f"{where}.mass"),
        inertia=_vec(_get(link, "inertia", where), 6, f"{where}.inertia"),
        com=_vec(link.get("com", (0.0, 0.0, 0.0)), 3, f"{where}.com"),
        origin_xyz=_vec(_get(link, "origin_xyz", where), 3, f"{where}.origin_xyz"),
        origin_rpy=_vec(link.get("origin_rpy", (0.0, 0.0, 0.0)), 3, f"{where}.origin_rpy"),
        axis=_vec(link.get("axis", (0.0, 0.0, 1.0)), 3, f"{where}.axis"),
    )


def _get(table: dict, key: str, where: str):
    if not isinstance(table, dict) or key not in table:
        raise ParameterError(f"{where}: missing key {key!r}")
    return table[key]


def _xyz(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def inertial_xml(body: SpatialBody, indent: str = "    ") -> str:
    """The ``<inertial>`` element of ``body``."""
    attrs = " ".join(f'{k}="{v!r}"' for k, v in zip(_INERTIA_KEYS, body.inertia, strict=True))
    return (
        f"{indent}<inertial>\n"
        f'{indent}  <origin xyz="{_xyz(body.com)}" rpy="0 0 0"/>\n'
        f'{indent}  <mass value="{body.mass!r}"/>\n'
        f"{indent}  <inertia {attrs}/>\n"
        f"{indent}</inertial>\n"
    )


def chain_to_urdf(chain: SpatialChain) -> str:
    """Return the URDF text of ``chain``."""
    out = [
        '<?xml version="1.0"?>\n',
        "<!-- Generated by ffsm_pin.spatial_urdf: edit the table, not this file. -->\n",
        f'<robot name="{escape(chain.name)}">\n',
        '  <material name="base_gold"><color rgba="0.85 0.7 0.25 1"/></material>\n',
        '  <material name="link_grey"><color rgba="0.55 0.6 0.7 1"/></material>\n',
        '  <material name="ee_red"><color rgba="0.85 0.15 0.15 1"/></material>\n',
        '  <link name="base_link">\n',
        inertial_xml(chain.base),
        "    <visual>\n",
        f'      <geometry><box size="{_xyz(chain.base_size)}"/></geometry>\n',
        '      <material name="base_gold"/>\n',
        "    </visual>\n",
        "  </link>\n",
    ]
    parent = "base_link"
    for i, link in enumerate(chain.links, start=1):
        lname = f"link{i}"
        out += [
            f'  <link name="{lname}">\n',
            inertial_xml(link),
            "    <visual>\n",
            f'      <origin xyz="{_xyz(link.com)}" rpy="0 0 0"/>\n',
            '      <geometry><sphere radius="0.05"/></geometry>\n',
            '      <material name="link_grey"/>\n',
            "    </visual>\n",
            "  </link>\n",
            f'  <joint name="joint{i}" type="revolute">\n',
            f'    <parent link="{parent}"/>\n',
            f'    <child link="{lname}"/>\n',
            f'    <origin xyz="{_xyz(link.origin_xyz)}" rpy="{_xyz(link.origin_rpy)}"/>\n',
            f'    <axis xyz="{_xyz(link.axis)}"/>\n',
            '    <limit lower="-6.283185307179586" upper="6.283185307179586" '
            'effort="1000" velocity="100"/>\n',
            "  </joint>\n",
        ]
        parent = lname
    ee = escape(chain.end_effector)
    out += [
        f'  <link name="{ee}_link">\n',
        "    <visual>\n",
        '      <geometry><sphere radius="0.04"/></geometry>\n',
        '      <material name="ee_red"/>\n',
        "    </visual>\n",
        "  </link>\n",
        f'  <joint name="{ee}" type="fixed">\n',
        f'    <parent link="{parent}"/>\n',
        f'    <child link="{ee}_link"/>\n',
        f'    <origin xyz="{_xyz(chain.ee_xyz)}" rpy="{_xyz(chain.ee_rpy)}"/>\n',
        "  </joint>\n",
        "</robot>\n",
    ]
    return "".join(out)


def write_urdf(chain: SpatialChain, path: str | Path) -> Path:
    """Write the URDF of ``chain`` to ``path`` and return the path."""
    path = Path(path)
    path.write_text(chain_to_urdf(chain))
    return path


def main(argv: list[str] | None = None) -> int:
    return table_to_urdf_main(
        "python -m ffsm_pin.spatial_urdf",
        "Write a spatial free-floating manipulator URDF from a TOML table.",
        chain_from_table,
        chain_to_urdf,
        argv,
    )


if __name__ == "__main__":
    raise SystemExit(main())
