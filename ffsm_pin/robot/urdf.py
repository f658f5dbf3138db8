"""Robot description files: where a URDF is found, and the documented repairs of its XML.

A robot is named by a path (absolute, or relative to a scenario file's folder or the working
directory), by the name of a robot shipped with the package (``"ffsm_planar4.urdf"``), or as
``"example-robot-data:<name>"`` for an arm of the installed ``example-robot-data`` package
(:data:`EXAMPLE_ROBOTS`; its files are read in place, never copied).
"""

from __future__ import annotations

import importlib.metadata
import math
import warnings
import xml.etree.ElementTree as ET
from importlib import resources
from pathlib import Path

from .._docstrings import doc_entries, fill_doc
from ..errors import RobotFileError, UrdfError, choices_text, did_you_mean, not_a_file

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    relative_to="""
        relative_to : str or Path or None
            Folder a relative path is looked up in first.""",
    text_source="""
        text : str
            URDF text.
        source : str
            Where it comes from, for the messages.""",
)

ERD_PREFIX = "example-robot-data:"

#: example-robot-data arms: name -> (URDF path under ``robots/``, suggested end effector,
#: joints to lock for a single chain).
EXAMPLE_ROBOTS: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "panda": (
        "panda_description/urdf/panda.urdf",
        "panda_hand",
        ("panda_finger_joint1", "panda_finger_joint2"),
    ),
    "kinova": ("kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", ()),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", "ee_link", ()),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "ee_link", ()),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", "ee_link", ()),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", "link7", ()),
    "z1": ("z1_description/urdf/z1.urdf", "link06", ("jointGripper",)),
}


#: The effort [N m] written into a repaired ``<limit>`` because urdfdom requires one; never used
#: as a torque limit (see :func:`joints_without_effort`).
PLACEHOLDER_EFFORT = "1000"


class UrdfWarning(UserWarning):
    """A URDF was accepted after a documented repair (e.g. a missing joint limit)."""


# ---------------------------------------------------------------------------- finding files
def urdf_dir() -> Path:
    """Folder of the shipped robot descriptions (package ``ffsm_pin.urdf``).

    Falls back to the top-level ``urdf/`` of a source checkout, for the case where the
    source tree shadows an installed copy on ``sys.path``.
    """
    try:
        return Path(str(resources.files("ffsm_pin.urdf")))
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[2] / "urdf"


def shipped_urdfs() -> list[str]:
    """Names of the robot descriptions shipped inside the package."""
    return sorted(p.name for p in urdf_dir().glob("*.urdf"))


@fill_doc(_DOC)
def resolve_urdf(urdf: str | Path, relative_to: str | Path | None = None) -> Path:
    """Find a URDF: a path (absolute, or relative to ``relative_to`` or the working
    directory), or the name of a robot shipped with the package (``"ffsm_planar4.urdf"``).

    Parameters
    ----------
    urdf : str or Path
        A path or the name of a shipped robot.
    %(relative_to)s

    Returns
    -------
    Path
        The URDF file.
    """
    candidates = []
    p = Path(urdf)
    if relative_to is not None and not p.is_absolute():
        candidates.append(Path(relative_to) / p)
    candidates.append(p)
    for c in candidates:
        if c.is_file():
            return c
    shipped = urdf_dir() / p.name
    if p.parent == Path(".") and shipped.is_file():
        return Path(str(shipped))
    for c in candidates:
        if c.exists():  # a folder, a FIFO, a device: never opened
            raise RobotFileError(f"URDF {str(urdf)!r}: {str(c)!r} {not_a_file(c)}")
    raise RobotFileError(
        f"URDF {str(urdf)!r} not found (looked in {', '.join(str(c) for c in candidates)}); "
        f"shipped robots: {choices_text(shipped_urdfs())}"
    )


#: (site folder, version) of an installed example-robot-data -> its share folder: finding it
#: reads the distribution's file list (some 1000 entries, 40-70 ms), once per process and
#: installation instead of once per robot load (every batch of a campaign loads its robot)
_ERD_SHARE: dict[tuple[str, str], Path] = {}
_ERD_PANDA = Path("panda_description/urdf/panda.urdf")


def example_robot_data_dir() -> Path:
    """The installed ``example-robot-data`` share folder (holding ``robots/``).

    Returns
    -------
    Path
        The folder; found once per installation (site folder and version) and process, and
        looked for again when it no longer holds the robots.
    """
    try:  # the Python module of older releases knows its model folder
        from example_robot_data.robots_loader import (  # type: ignore[import-not-found]
            EXAMPLE_ROBOT_DATA_MODEL_DIR,
        )

        robots = Path(EXAMPLE_ROBOT_DATA_MODEL_DIR)
        if (robots / _ERD_PANDA).is_file():
            return robots.parent
    except (ImportError, AttributeError, TypeError):
        pass
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise RobotFileError(
            "the example-robot-data package is not installed (pip install example-robot-data)"
        ) from None
    key = (str(dist.locate_file("")), str(dist.version))
    share = _ERD_SHARE.get(key)
    if share is not None and (share / "robots" / _ERD_PANDA).is_file():
        return share
    for f in dist.files or ():
        parts = Path(str(f)).parts
        if "example-robot-data" in parts and "robots" in parts:
            i = parts.index("robots")
            if i > 0 and parts[i - 1] == "example-robot-data":
                share = Path(str(dist.locate_file(Path(*parts[:i]))))
                _ERD_SHARE[key] = share
                return share
    raise RobotFileError("example-robot-data is installed but ships no robots/ folder")


def example_robot_name(urdf: str | Path) -> str | None:
    """``"panda"`` for ``"example-robot-data:panda"``, None for anything else."""
    if isinstance(urdf, str) and urdf.startswith(ERD_PREFIX):
        return urdf[len(ERD_PREFIX) :]
    return None


@fill_doc(_DOC)
def resolve_source(
    urdf: str | Path, relative_to: str | Path | None = None
) -> tuple[Path, tuple[Path, ...]]:
    """(URDF path, package dirs) for a path, a shipped name or ``example-robot-data:<name>``.

    The package dirs are where ``package://NAME/...`` mesh paths of the URDF resolve.

    Parameters
    ----------
    urdf : str or Path
        A path, a shipped name or ``example-robot-data:<name>``.
    %(relative_to)s

    Returns
    -------
    path : Path
        The URDF file.
    package_dirs : tuple of Path
        Where its ``package://`` paths resolve.
    """
    name = example_robot_name(urdf)
    if name is not None:
        if name not in EXAMPLE_ROBOTS:
            raise RobotFileError(
                f"unknown example-robot-data robot {name!r}"
                f"{did_you_mean(name, EXAMPLE_ROBOTS)}; valid names: "
                f"{choices_text(EXAMPLE_ROBOTS)}"
            )
        share = example_robot_data_dir()
        path = share / "robots" / EXAMPLE_ROBOTS[name][0]
        if not path.is_file():
            raise RobotFileError(f"example-robot-data robot {name!r}: {path} is missing")
        return path, (share.parent,)
    path = resolve_urdf(urdf, relative_to)
    return path, (path.parent,)


def read_urdf(path: Path) -> str:
    """The text of a URDF file; :class:`RobotFileError` when it cannot be read."""
    try:
        return path.read_text()
    except OSError as exc:
        raise RobotFileError(f"cannot read URDF {str(path)!r}: {exc.strerror}") from None


# ---------------------------------------------------------------------------- XML
@fill_doc(_DOC)
def parse_urdf(text: str, source: str) -> ET.Element:
    """The ``<robot>`` element of a URDF text; :class:`UrdfError` for anything else.

    Parameters
    ----------
    %(text_source)s

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``<robot>`` element.
    """
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise UrdfError(f"{source}: not well-formed XML ({exc})") from None
    if root.tag != "robot":
        raise UrdfError(f"{source}: root element is <{root.tag}>, expected <robot>")
    return root


#: Joint types whose URDF ``<limit>`` gives an effort limit (urdfdom reads it for these).
LIMITED_TYPES = ("revolute", "continuous", "prismatic")


def joints_without_effort(root: ET.Element) -> tuple[str, ...]:
    """Names of the movable joints whose file gives no effort limit (no ``<limit>``, or a
    ``<limit>`` without ``effort``), in file order; read before :func:`repair_limits`, whose
    invented value is no limit."""
    return tuple(
        joint.get("name", "?")
        for joint in root.iter("joint")
        if joint.get("type") in LIMITED_TYPES
        and ((limit := joint.find("limit")) is None or limit.get("effort") is None)
    )


def repair_limits(root: ET.Element, source: str) -> bool:
    """Make every 'continuous' joint 'revolute' and give every revolute joint without
    ``<limit>`` one, each with a :class:`UrdfWarning` naming the joint; True if anything changed.

    urdfdom (Pinocchio's parser) rejects revolute joints without limits outright; SPARTpy's
    bundled URDFs are an example. The position and velocity limits are not enforced by the
    simulator; the effort written here is a placeholder for the parser, never a torque limit
    (:attr:`~ffsm_pin.robot.Robot.no_effort_limit` names these joints, and
    ``actuators.torque_limit = "urdf"`` refuses them).

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The ``<robot>`` element, repaired in place.
    source : str
        Where it comes from, for the warnings.

    Returns
    -------
    bool
        True if anything changed.
    """
    changed = False
    for joint in root.iter("joint"):
        name = joint.get("name", "?")
        if joint.get("type") == "continuous":
            warnings.warn(
                f"{source}: joint {name!r} is 'continuous'; treated as 'revolute' with "
                "position limits +-2 pi (joint position limits are not enforced by the simulator)",
                UrdfWarning,
                stacklevel=4,
            )
            joint.set("type", "revolute")
            limit = joint.find("limit")
            if limit is not None:  # a continuous joint's <limit> may give effort and velocity only
                limit.set("lower", limit.get("lower", repr(-2 * math.pi)))
                limit.set("upper", limit.get("upper", repr(2 * math.pi)))
            changed = True
        if joint.get("type") == "revolute" and joint.find("limit") is None:
            warnings.warn(
                f"{source}: revolute joint {name!r} has no <limit>; it gets position limits "
                "+-2 pi (not enforced by the simulator) and no torque limit "
                "(actuators.torque_limit = 'urdf' refuses this joint: give a number instead)",
                UrdfWarning,
                stacklevel=4,
            )
            ET.SubElement(
                joint,
                "limit",
                lower=repr(-2 * math.pi),
                upper=repr(2 * math.pi),
                effort=PLACEHOLDER_EFFORT,
                velocity="100",
            )
            changed = True
    return changed


@fill_doc(_DOC)
def add_missing_limits(text: str, source: str = "URDF") -> str:
    """Return URDF text repaired by :func:`repair_limits` (the text itself when nothing was
    missing).

    Parameters
    ----------
    %(text_source)s

    Returns
    -------
    str
        The repaired text.
    """
    root = parse_urdf(text, source)
    if repair_limits(root, source):
        return ET.tostring(root, encoding="unicode")
    return text


def root_links(root: ET.Element) -> list[str]:
    """Names of the links that are no joint's child (a tree has exactly one)."""
    links = [link.get("name", "") for link in root.findall("link")]
    children = {
        child.get("link") for j in root.findall("joint") if (child := j.find("child")) is not None
    }
    return [name for name in links if name not in children]
