"""Spatial robots and synthetic runs for the replay tests, without the spatial loader.

``ArmOnFreeFlyer`` has what the replay asks of a robot (``model``, ``urdf_xml``, ``urdf_path``,
``package_dirs``, optionally ``satellite.size``). :func:`panda` loads example-robot-data's Panda
(files only: example-robot-data 6 ships no Python module) on a free-flyer root;
:func:`synthetic_spatial_result` makes a plausible motion (the base drifts, turns about a tilted
axis, the joints swing) with the end effector computed by Pinocchio and a reference converging
to it. The numbers are not a closed-loop run.
"""

from __future__ import annotations

import importlib.metadata as md
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from ffsm_pin.sim.result import RunResult

DATA = Path(__file__).resolve().parents[1] / "data"


@dataclass(frozen=True)
class Satellite:
    size: tuple[float, float, float]  # box edges [m]


@dataclass(frozen=True)
class ArmOnFreeFlyer:
    model: pin.Model
    urdf_xml: str
    urdf_path: Path
    package_dirs: tuple[Path, ...] = ()
    satellite: Satellite | None = None


def erd_share() -> Path:
    """The share folder of example-robot-data (holds example-robot-data/robots/...)."""
    dist = md.distribution("example-robot-data")
    return Path(str(dist.locate_file("cmeel.prefix/share")))


def free_flyer(urdf_path: Path, urdf_xml: str | None = None, **kw) -> ArmOnFreeFlyer:
    xml = urdf_xml if urdf_xml is not None else urdf_path.read_text(encoding="utf-8")
    model = pin.buildModelFromXML(xml, pin.JointModelFreeFlyer())
    model.gravity.setZero()
    return ArmOnFreeFlyer(model, xml, urdf_path, **kw)


def panda(**kw) -> ArmOnFreeFlyer:
    path = erd_share() / "example-robot-data/robots/panda_description/urdf/panda.urdf"
    return free_flyer(path, package_dirs=(erd_share(),), **kw)


def with_satellite(
    robot: ArmOnFreeFlyer, size=(0.6, 0.6, 0.6), mount_z: float = 0.3, mass: float = 200.0
) -> ArmOnFreeFlyer:
    """The arm mounted on a satellite link without visuals (a new root link and a fixed
    joint in the URDF text, as the spatial loader does), ``satellite.size`` given."""
    root = ET.fromstring(robot.urdf_xml)
    children = {c.get("link") for c in root.iter("child")}
    arm_root = next(e.get("name") for e in root.iter("link") if e.get("name") not in children)
    inertia = mass * (size[0] ** 2 + size[1] ** 2) / 12.0
    satellite = ET.fromstring(
        f'<link name="satellite"><inertial><mass value="{mass}"/>'
        f'<inertia ixx="{inertia}" iyy="{inertia}" izz="{inertia}" ixy="0" ixz="0" iyz="0"/>'
        "</inertial></link>"
    )
    mount = ET.fromstring(
        '<joint name="satellite_mount" type="fixed"><parent link="satellite"/>'
        f'<child link="{arm_root}"/><origin xyz="0 0 {mount_z}" rpy="0 0 0"/></joint>'
    )
    root.insert(0, mount)
    root.insert(0, satellite)
    xml = ET.tostring(root, encoding="unicode")
    return free_flyer(
        robot.urdf_path, xml, package_dirs=robot.package_dirs, satellite=Satellite(tuple(size))
    )


def synthetic_spatial_result(
    robot: ArmOnFreeFlyer, ee_frame: str, duration: float = 3.0, dt: float = 1e-2
) -> RunResult:
    """A RunResult with ``t``, ``q``, ``z_e`` (position + MRP columns) and ``z_e_d``."""
    model, data = robot.model, robot.model.createData()
    t = np.arange(round(duration / dt) + 1) * dt
    m = model.nq - 7
    axis = np.array([1.0, -2.0, 3.0]) / np.sqrt(14.0)
    q0 = pin.neutral(model)[7:] + 0.3
    q = np.zeros((len(t), model.nq))
    for i, ti in enumerate(t):
        pos = np.array([0.2, -0.1, 0.3]) * ti
        quat = pin.Quaternion(pin.exp3(0.4 * ti * axis)).coeffs()  # x, y, z, w
        joints = q0 + 0.4 * np.sin(1.5 * ti + np.arange(m))
        joints = np.clip(joints, model.lowerPositionLimit[7:], model.upperPositionLimit[7:])
        q[i] = np.concatenate([pos, quat, joints])
    fid = model.getFrameId(ee_frame)
    p_e = np.zeros((len(t), 3))
    for i in range(len(t)):
        pin.framesForwardKinematics(model, data, q[i])
        p_e[i] = data.oMf[fid].translation
    z_e = np.column_stack([p_e, np.zeros((len(t), 3))])
    z_e_d = z_e + np.exp(-t)[:, None] * np.array([0.15, -0.1, 0.2, 0.0, 0.0, 0.0])
    return RunResult(
        scheme="ppc",
        robot=model.name,
        dt=dt,
        duration=duration,
        steps=len(t) - 1,
        wall_time_s=1.0,
        completed=True,
        stop_reason=None,
        signals={"t": t, "q": q, "z_e": z_e, "z_e_d": z_e_d},
        scenario_name="synthetic-spatial",
    )
