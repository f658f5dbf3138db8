"""A satellite body added under an arm's root link, for arm-only URDFs."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, UrdfError, check_keys


@dataclass(frozen=True)
class Satellite:
    """A satellite body added under an arm's root link (for arm-only URDFs).

    Attributes
    ----------
    mass : float
        Mass [kg].
    inertia : tuple of float
        (ixx, iyy, izz, ixy, ixz, iyz) about the satellite's CoM, which is the origin of the
        new root link [kg m^2].
    size : tuple of float
        The visual box [m].
    mount_xyz : tuple of float
        Where the arm's root link is mounted in the satellite frame [m].
    mount_rpy : tuple of float
        Its roll-pitch-yaw in the satellite frame [rad].
    name : str
        Name of the new root link.
    """

    mass: float = 500.0  # [kg]
    inertia: tuple[float, ...] = (80.0, 80.0, 80.0, 0.0, 0.0, 0.0)
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)
    mount_xyz: tuple[float, float, float] = (0.0, 0.0, 0.5)
    mount_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = "satellite"

    def __post_init__(self) -> None:
        for key, n in (("inertia", 6), ("size", 3), ("mount_xyz", 3), ("mount_rpy", 3)):
            value = tuple(float(x) for x in getattr(self, key))
            if len(value) != n:
                raise ParameterError(f"satellite.{key}: expected {n} numbers, got {value}")
            object.__setattr__(self, key, value)
        object.__setattr__(self, "mass", float(self.mass))

    @classmethod
    def from_mapping(cls, table: Mapping) -> Satellite:
        """Build from a dict (e.g. a scenario's ``[robot.satellite]`` table); unknown keys are
        errors."""
        valid = ("mass", "inertia", "size", "mount_xyz", "mount_rpy", "name")
        check_keys(table, valid, "satellite")
        return cls(**dict(table))

    def inertia_matrix(self) -> np.ndarray:
        """The 3x3 inertia about the satellite's CoM, satellite frame [kg m^2]."""
        xx, yy, zz, xy, xz, yz = self.inertia
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])

    def add_to(self, root: ET.Element, arm_root: str, source: str) -> None:
        """Insert this satellite into a URDF's XML as the new root link, carrying ``arm_root``
        through a fixed joint.

        Parameters
        ----------
        root : xml.etree.ElementTree.Element
            The URDF's ``<robot>`` element, changed in place.
        arm_root : str
            The arm's root link.
        source : str
            Where the URDF comes from, for the message.
        """
        names = {link.get("name") for link in root.findall("link")}
        if self.name in names:
            raise UrdfError(
                f"{source}: satellite link name {self.name!r} is already a link of the URDF"
            )
        link = ET.Element("link", name=self.name)
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=repr(self.mass))
        keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
        moments = {k: repr(v) for k, v in zip(keys, self.inertia, strict=True)}
        ET.SubElement(inertial, "inertia", moments)
        visual = ET.SubElement(link, "visual")
        geometry = ET.SubElement(visual, "geometry")
        ET.SubElement(geometry, "box", size=" ".join(repr(s) for s in self.size))
        joint = ET.Element("joint", name=f"{self.name}_mount", type="fixed")
        ET.SubElement(joint, "parent", link=self.name)
        ET.SubElement(joint, "child", link=arm_root)
        ET.SubElement(
            joint,
            "origin",
            xyz=" ".join(repr(v) for v in self.mount_xyz),
            rpy=" ".join(repr(v) for v in self.mount_rpy),
        )
        root.insert(0, joint)
        root.insert(0, link)
