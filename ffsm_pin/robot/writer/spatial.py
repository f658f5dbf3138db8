"""Write the URDF of a spatial free-floating serial manipulator from a small table.

The spatial counterpart of :mod:`ffsm_pin.robot.writer.planar`. The table is a TOML file (or the
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

Command line (one for both geometries, :mod:`ffsm_pin.robot.writer`)::

    python -m ffsm_pin.robot.writer table.toml -o robot.urdf
"""

from __future__ import annotations

from dataclasses import dataclass

from ..._docstrings import doc_entries, fill_doc
from ...errors import ParameterError
from ._xml import end_effector, get, header, num, revolute_joint, vec

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    mass="""
        mass : float
            Mass [kg].""",
    inertia="""
        inertia : tuple of float
            (ixx, iyy, izz, ixy, ixz, iyz) about the CoM in the body frame [kg m^2].""",
    com="""
        com : tuple of float
            CoM in the body frame [m].""",
)

_INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")  # table order (as the scenario files)


def _v3(x, key: str) -> tuple[float, float, float]:
    return vec(x, 3, key)  # type: ignore[return-value]  # vec checked the length


def _v6(x, key: str) -> tuple[float, float, float, float, float, float]:
    return vec(x, 6, key)  # type: ignore[return-value]  # vec checked the length


@dataclass(frozen=True)
@fill_doc(_DOC)
class SpatialBody:
    """Mass properties of one rigid body: mass [kg], inertia (ixx iyy izz ixy ixz iyz) about
    the CoM in the body frame [kg m^2], CoM in the body frame [m].

    Attributes
    ----------
    %(mass)s
    %(inertia)s
    %(com)s
    """

    mass: float
    inertia: tuple[float, float, float, float, float, float]
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", num(self.mass, "mass"))
        object.__setattr__(self, "inertia", _v6(self.inertia, "inertia"))
        object.__setattr__(self, "com", _v3(self.com, "com"))


@dataclass(frozen=True)
@fill_doc(_DOC)
class SpatialLink(SpatialBody):
    """A link: its mass properties and its joint (placement in the parent, axis).

    Attributes
    ----------
    %(mass)s
    %(inertia)s
    %(com)s
    origin_xyz : tuple of float
        Joint origin in the parent's frame [m].
    origin_rpy : tuple of float
        Joint roll-pitch-yaw in the parent's frame [rad].
    axis : tuple of float
        Joint axis in the joint frame (not zero).
    """

    origin_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    origin_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "origin_xyz", _v3(self.origin_xyz, "origin_xyz"))
        object.__setattr__(self, "origin_rpy", _v3(self.origin_rpy, "origin_rpy"))
        axis = _v3(self.axis, "axis")
        if sum(a * a for a in axis) == 0.0:
            raise ParameterError("axis: a joint axis must not be zero")
        object.__setattr__(self, "axis", axis)


@dataclass(frozen=True)
class SpatialChain:
    """A floating base (satellite) carrying a serial chain of revolute links.

    Attributes
    ----------
    name : str
        The robot's name.
    base : SpatialBody
        The base's mass properties.
    links : tuple of SpatialLink
        The links, base outwards.
    end_effector : str
        Name of the end-effector frame.
    ee_xyz : tuple of float
        End-effector frame origin in the last link [m].
    ee_rpy : tuple of float
        End-effector frame roll-pitch-yaw in the last link [rad].
    base_size : tuple of float
        Visual box of the base [m].
    """

    name: str
    base: SpatialBody
    links: tuple[SpatialLink, ...]
    end_effector: str = "ee"
    ee_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ee_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_size: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "ee_xyz", _v3(self.ee_xyz, "ee.xyz"))
        object.__setattr__(self, "ee_rpy", _v3(self.ee_rpy, "ee.rpy"))
        object.__setattr__(self, "base_size", _v3(self.base_size, "base.size"))
        if not self.links:
            raise ParameterError(f"robot {self.name!r}: at least one link is needed")
        for i, body in enumerate((self.base, *self.links)):
            what = "base" if i == 0 else f"links[{i}]"
            if not body.mass > 0:
                raise ParameterError(f"{what}: mass must be > 0, got {body.mass}")


def chain_from_table(table: dict) -> SpatialChain:
    """Build a :class:`SpatialChain` from the dict form of the TOML table."""
    base = get(table, "base", "robot table")
    links = get(table, "links", "robot table")
    ee = table.get("ee", {})
    return SpatialChain(
        name=str(table.get("name", "spatial_ffsm")),
        base=SpatialBody(
            mass=num(get(base, "mass", "base"), "base.mass"),
            inertia=_v6(get(base, "inertia", "base"), "base.inertia"),
            com=_v3(base.get("com", (0.0, 0.0, 0.0)), "base.com"),
        ),
        base_size=_v3(base.get("size", (1.0, 1.0, 1.0)), "base.size"),
        end_effector=str(table.get("end_effector", "ee")),
        ee_xyz=_v3(ee.get("xyz", (0.0, 0.0, 0.0)), "ee.xyz"),
        ee_rpy=_v3(ee.get("rpy", (0.0, 0.0, 0.0)), "ee.rpy"),
        links=tuple(_link(link, i) for i, link in enumerate(links, start=1)),
    )


def _link(link: dict, i: int) -> SpatialLink:
    where = f"links[{i}]"
    return SpatialLink(
        mass=num(get(link, "mass", where), f"{where}.mass"),
        inertia=_v6(get(link, "inertia", where), f"{where}.inertia"),
        com=_v3(link.get("com", (0.0, 0.0, 0.0)), f"{where}.com"),
        origin_xyz=_v3(get(link, "origin_xyz", where), f"{where}.origin_xyz"),
        origin_rpy=_v3(link.get("origin_rpy", (0.0, 0.0, 0.0)), f"{where}.origin_rpy"),
        axis=_v3(link.get("axis", (0.0, 0.0, 1.0)), f"{where}.axis"),
    )


def _xyz(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def inertial_xml(body: SpatialBody, indent: str = "    ") -> str:
    """The ``<inertial>`` element of ``body``.

    Parameters
    ----------
    body : SpatialBody
        The body.
    indent : str
        Indentation of the element.

    Returns
    -------
    str
        The element's XML.
    """
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
        *header(chain.name),
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
            *revolute_joint(
                f"joint{i}",
                parent,
                lname,
                _xyz(link.origin_xyz),
                _xyz(link.origin_rpy),
                _xyz(link.axis),
            ),  # fmt: skip
        ]
        parent = lname
    out += end_effector(chain.end_effector, parent, _xyz(chain.ee_xyz), _xyz(chain.ee_rpy), 0.04)
    return "".join(out)


__all__ = [
    "SpatialBody",
    "SpatialChain",
    "SpatialLink",
    "chain_from_table",
    "chain_to_urdf",
    "inertial_xml",
]
