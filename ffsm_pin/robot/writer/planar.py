"""Write the URDF of a planar free-floating serial manipulator from a small table.

The table is a TOML file (or the equivalent dict)::

    name = "ffsm_planar4"
    end_effector = "ee"            # optional, default "ee"

    [base]
    mass = 61.2                    # [kg]
    inertia = 26.112               # about the base CoM, z axis [kg m^2]
    com = [0.0, 0.0]               # base CoM in the base frame [m]
    mount = [0.8, 0.0]             # joint 1 in the base frame [m]
    size = [1.6, 1.6]              # visual box [m] (optional)

    [[links]]                      # one table per link, base outwards
    mass = 6.3
    inertia = 1.029
    length = 1.4                   # next joint (or the end effector) at (length, 0) [m]
    com = [0.7, 0.0]               # link CoM in the link frame [m]
    # tip = [1.4, 0.1]             # optional: next joint / end effector off the x axis
    # axis = -1                    # optional: joint axis -z instead of +z

Every joint is revolute about z, the end-effector frame is a fixed child of the last link at
its tip. The 3-D inertia written to the URDF is (I, I, I) so that it is physically valid for
3-D engines (MuJoCo) while the planar dynamics only ever use I_zz.

Command line (one for both geometries, :mod:`ffsm_pin.robot.writer`)::

    python -m ffsm_pin.robot.writer urdf/ffsm_planar4.toml -o urdf/ffsm_planar4.urdf
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..._docstrings import doc_entries, fill_doc
from ...errors import ParameterError
from ._xml import end_effector, get, header, num, revolute_joint, vec

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    mass="""
        mass : float
            Mass [kg].""",
    inertia="""
        inertia : float
            I_zz about the body CoM [kg m^2].""",
    com="""
        com : tuple of float
            CoM in the body frame [m].""",
)


@dataclass(frozen=True)
@fill_doc(_DOC)
class PlanarBody:
    """Mass properties of one rigid body of the chain (planar).

    Attributes
    ----------
    %(mass)s
    %(inertia)s
    %(com)s
    """

    mass: float  # [kg]
    inertia: float  # I_zz about the body CoM [kg m^2]
    com: tuple[float, float] = (0.0, 0.0)  # CoM in the body frame [m]

    def __post_init__(self) -> None:
        # plain floats, so that the URDF text never shows numpy reprs
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "inertia", float(self.inertia))
        object.__setattr__(self, "com", _pair(self.com, "com"))


@dataclass(frozen=True)
@fill_doc(_DOC)
class PlanarLink(PlanarBody):
    """A link: its mass properties and where its child joint (or tip) sits.

    Attributes
    ----------
    %(mass)s
    %(inertia)s
    %(com)s
    tip : tuple of float
        Child joint / end effector in the link frame [m].
    axis : int
        +1: joint axis +z, -1: joint axis -z.
    """

    tip: tuple[float, float] = (1.0, 0.0)  # child joint / end effector in the link frame [m]
    axis: int = 1  # +1: joint axis +z, -1: joint axis -z

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "tip", _pair(self.tip, "tip"))
        if self.axis not in (1, -1):
            raise ParameterError(f"link axis must be 1 or -1, got {self.axis!r}")
        object.__setattr__(self, "axis", int(self.axis))


@dataclass(frozen=True)
class PlanarChain:
    """A planar floating base carrying a serial chain of revolute-z links.

    Attributes
    ----------
    name : str
        The robot's name.
    base : PlanarBody
        The base's mass properties.
    mount : tuple of float
        Joint 1 in the base frame [m].
    links : tuple of PlanarLink
        The links, base outwards.
    end_effector : str
        Name of the end-effector frame.
    base_size : tuple of float
        Visual box of the base [m].
    joint_names : tuple of str
        Joint names; empty: joint1, joint2, ...
    """

    name: str
    base: PlanarBody
    mount: tuple[float, float]  # joint 1 in the base frame [m]
    links: tuple[PlanarLink, ...]
    end_effector: str = "ee"
    base_size: tuple[float, float] = (1.0, 1.0)  # visual box [m]
    joint_names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "mount", _pair(self.mount, "mount"))
        object.__setattr__(self, "base_size", _pair(self.base_size, "size"))
        object.__setattr__(self, "links", tuple(self.links))
        if not self.links:
            raise ParameterError(f"robot {self.name!r}: at least one link is needed")
        for i, body in enumerate((self.base, *self.links)):
            what = "base" if i == 0 else f"link {i}"
            if not body.mass > 0:
                raise ParameterError(f"{what}: mass must be > 0, got {body.mass}")
            if not body.inertia > 0:
                raise ParameterError(f"{what}: inertia must be > 0, got {body.inertia}")
        for i, link in enumerate(self.links, start=1):
            if link.axis not in (1, -1):
                raise ParameterError(f"link {i}: axis must be 1 or -1, got {link.axis}")


def chain_from_table(table: dict) -> PlanarChain:
    """Build a :class:`PlanarChain` from the dict form of the TOML table."""
    base = get(table, "base", "robot table")
    links = get(table, "links", "robot table")
    return PlanarChain(
        name=str(table.get("name", "planar_ffsm")),
        base=PlanarBody(
            mass=num(get(base, "mass", "base"), "base.mass"),
            inertia=num(get(base, "inertia", "base"), "base.inertia"),
            com=_pair(base.get("com", (0.0, 0.0)), "base.com"),
        ),
        mount=_pair(get(base, "mount", "base"), "base.mount"),
        base_size=_pair(base.get("size", (1.0, 1.0)), "base.size"),
        end_effector=str(table.get("end_effector", "ee")),
        links=tuple(_link(link, i) for i, link in enumerate(links, start=1)),
    )


def _link(link: dict, i: int) -> PlanarLink:
    where = f"links[{i}]"
    length = link.get("length")
    if length is None and ("com" not in link or "tip" not in link):
        raise ParameterError(f"{where}: missing key 'length' (or both 'com' and 'tip')")
    length = None if length is None else num(length, f"{where}.length")
    axis = num(link.get("axis", 1), f"{where}.axis")
    if axis not in (1.0, -1.0):
        raise ParameterError(f"{where}.axis must be 1 or -1, got {link.get('axis')!r}")
    return PlanarLink(
        mass=num(get(link, "mass", where), f"{where}.mass"),
        inertia=num(get(link, "inertia", where), f"{where}.inertia"),
        com=_pair(link.get("com", (0.5 * (length or 0.0), 0.0)), f"{where}.com"),
        tip=_pair(link.get("tip", (length, 0.0)), f"{where}.tip"),
        axis=int(axis),
    )


def _pair(x, key: str = "vector") -> tuple[float, float]:
    return vec(x, 2, key, "[x, y]")  # type: ignore[return-value]


def _inertial(mass: float, inertia: float, com: tuple[float, float]) -> str:
    return (
        "    <inertial>\n"
        f'      <origin xyz="{com[0]!r} {com[1]!r} 0" rpy="0 0 0"/>\n'
        f'      <mass value="{mass!r}"/>\n'
        f'      <inertia ixx="{inertia!r}" ixy="0" ixz="0" iyy="{inertia!r}" iyz="0" '
        f'izz="{inertia!r}"/>\n'
        "    </inertial>\n"
    )


def _bar_visual(tip: tuple[float, float], width: float, material: str) -> str:
    length = math.hypot(*tip)
    if length == 0.0:
        return ""
    yaw = math.atan2(tip[1], tip[0])
    return (
        "    <visual>\n"
        f'      <origin xyz="{tip[0] / 2!r} {tip[1] / 2!r} 0" rpy="0 0 {yaw!r}"/>\n'
        f'      <geometry><box size="{length!r} {width!r} {width!r}"/></geometry>\n'
        f'      <material name="{material}"/>\n'
        "    </visual>\n"
    )


def chain_to_urdf(chain: PlanarChain) -> str:
    """Return the URDF text of ``chain``."""
    n = len(chain.links)
    names = chain.joint_names or tuple(f"joint{i}" for i in range(1, n + 1))
    out = [
        *header(chain.name),
        '  <link name="base_link">\n',
        _inertial(chain.base.mass, chain.base.inertia, chain.base.com),
        "    <visual>\n",
        '      <origin xyz="0 0 0" rpy="0 0 0"/>\n',
        f'      <geometry><box size="{chain.base_size[0]!r} {chain.base_size[1]!r} 0.3"/>'
        "</geometry>\n",
        '      <material name="base_gold"/>\n',
        "    </visual>\n",
        "  </link>\n",
    ]
    parent, origin = "base_link", chain.mount
    for i, link in enumerate(chain.links, start=1):
        lname = f"link{i}"
        out += [
            f'  <link name="{lname}">\n',
            _inertial(link.mass, link.inertia, link.com),
            _bar_visual(link.tip, 0.12, "link_grey"),
            "  </link>\n",
            *revolute_joint(
                names[i - 1],
                parent,
                lname,
                f"{origin[0]!r} {origin[1]!r} 0",
                "0 0 0",
                f"0 0 {link.axis}",
            ),  # fmt: skip
        ]
        parent, origin = lname, link.tip
    xyz = f"{origin[0]!r} {origin[1]!r} 0"
    out += end_effector(chain.end_effector, parent, xyz, "0 0 0", 0.1)
    return "".join(out)


__all__ = ["PlanarBody", "PlanarChain", "PlanarLink", "chain_from_table", "chain_to_urdf"]
