"""The replay's marks of a capture and of the wheels (docs/capture.md, "The replay").

:func:`capture_marks` gives the moving marks :func:`~.scene.build_scene` adds to a run's scene:

* ``grasp_target``: a small triad (x red, y green, z blue) at the target's grasp frame, the
  recorded ``target_pose`` times the target's ``grasp`` (a run with a ``[target]``);
* ``grasp_hand``: a triad at the hand's grasp frame, the end-effector frame of the recorded
  ``q`` times ``[capture] hand_xyz``, ``hand_rpy`` (a run with ``[capture]``); from the capture
  on the two triads move together (the weld);
* ``wheel_momentum``: with ``[robot.satellite.wheels]``, an arrow (a thin cylinder) from the
  bus origin along the momentum the wheels store, R_b A h (world frame), its length
  proportional to |A h| (:data:`ARROW_LENGTH` at the run's largest).

Each :class:`Mark` holds its object and its placements (and scales) at the replay's frames.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's deprecated zmq.eventloop.ioloop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat.geometry as mg

GRASP_HAND = "grasp_hand"  # node of the hand's grasp frame ([capture])
GRASP_TARGET = "grasp_target"  # node of the target's grasp frame ([target])
WHEEL_MOMENTUM = "wheel_momentum"  # node of the wheels' stored momentum ([...wheels])
TRIAD_SCALE = 0.08  # length of a grasp triad's axes [m]
ARROW_LENGTH = 0.5  # the wheels' arrow at the run's largest stored momentum [m]
ARROW_RADIUS = 0.012  # [m]
_ARROW_COLOR = 0xAA33CC  # purple
_HIDDEN = 1e-6  # the arrow's length scale when the wheels store nothing


@dataclass(frozen=True)
class Mark:
    """One moving mark of the scene.

    Attributes
    ----------
    name : str
        Its node under the run's scene path.
    shape : object
        The meshcat object (geometry, or ``mg.triad``'s line segments).
    material : object or None
        Its material (None: the object carries its own).
    placements : ndarray, shape (frames, 4, 4)
        Where it is at each replay frame, inertial frame.
    scales : ndarray, shape (frames, 3) or None
        Its scale at each frame (None: unscaled).
    """

    name: str
    shape: object
    material: object
    placements: np.ndarray
    scales: np.ndarray | None = None

    def draw(self, group) -> None:
        """Put the object in the scene at its first frame's placement (the still picture).

        Parameters
        ----------
        group : meshcat.Visualizer
            The run's scene path.
        """
        node = group[self.name]
        if self.material is None:
            node.set_object(self.shape)
        else:
            node.set_object(self.shape, self.material)
        node.set_transform(self.placements[0])
        if self.scales is not None:
            node.set_property("scale", [float(x) for x in self.scales[0]])

    def key(self, frame, k: int) -> None:
        """Key the mark at replay frame ``k``.

        Parameters
        ----------
        frame : meshcat.animation.AnimationFrameVisualizer
            The animation's frame at the run's scene path.
        k : int
            Index into :attr:`placements`.
        """
        frame[self.name].set_transform(self.placements[k])
        if self.scales is not None:
            frame[self.name].set_property("scale", "vector3", [float(x) for x in self.scales[k]])


def capture_marks(robot, result, frames: np.ndarray, targets: np.ndarray | None) -> list[Mark]:
    """The marks of a run's target, capture and wheels (none for a run without them).

    Parameters
    ----------
    robot : ReplayRobot
        The robot drawn; ``ee_frame_id`` gives the hand (no hand triad without it).
    result : RunResult
        The run: its ``target`` (``grasp``), ``capture`` (``hand_grasp``), ``outcomes`` (the
        wheels' ``wheels``) and ``wheel_momentum``.
    frames : ndarray of int
        The recorded rows of the replay's frames (:func:`~.scene.frame_indices`).
    targets : ndarray, shape (frames, 4, 4) or None
        The target frame's placements at those frames (None without a target).

    Returns
    -------
    list of Mark
        ``grasp_target``, ``grasp_hand``, ``wheel_momentum``, those the run has.
    """
    marks = []
    q = np.asarray(result["q"], dtype=float)[frames]
    grasp = getattr(getattr(result, "target", None), "grasp", None)
    if targets is not None and grasp is not None:
        marks.append(_triad(GRASP_TARGET, targets @ grasp.homogeneous))
    capture = getattr(result, "capture", None)
    ee = getattr(robot, "ee_frame_id", None)
    if capture is not None and ee is not None:
        marks.append(_triad(GRASP_HAND, hand_grasp_placements(robot.model, ee, q, capture)))
    wheels = next((w for w in (getattr(x, "wheels", None) for x in result.outcomes) if w), None)
    if wheels is not None and "wheel_momentum" in result:
        h = np.asarray(result["wheel_momentum"], dtype=float)[frames]
        marks.append(wheel_arrow(robot.model, wheels, q, h))
    return marks


def hand_grasp_placements(model: pin.Model, ee_frame: int, q: np.ndarray, capture) -> np.ndarray:
    """The hand's grasp frame at each configuration: oMf of the end-effector frame times the
    ``hand_grasp`` offset (xyz [m], rpy [rad]) of a :class:`~.capture_run.CaptureOutcome`.

    Parameters
    ----------
    model : pin.Model
        The robot's model.
    ee_frame : int
        The end-effector frame's index.
    q : ndarray, shape (frames, nq)
        Configurations.
    capture : CaptureOutcome
        Its ``hand_grasp``.

    Returns
    -------
    ndarray, shape (frames, 4, 4)
        The placements, inertial frame.
    """
    offset = np.asarray(capture.hand_grasp, dtype=float)
    hand = pin.SE3(pin.rpy.rpyToMatrix(*offset[3:]), offset[:3])
    data = model.createData()
    out = np.empty((len(q), 4, 4))
    for k, qk in enumerate(q):
        pin.forwardKinematics(model, data, qk)
        out[k] = (pin.updateFramePlacement(model, data, ee_frame) * hand).homogeneous
    return out


def wheel_arrow(model: pin.Model, wheels, q: np.ndarray, h: np.ndarray) -> Mark:
    """The arrow of the wheels' stored momentum R_b A h: a cylinder from the bus origin along
    it, its length ``ARROW_LENGTH`` |A h| / max |A h| (the cylinder's axis is its local y).

    Parameters
    ----------
    model : pin.Model
        The robot's model (the bus is its root joint).
    wheels : Wheels
        The wheels (axes in the bus frame).
    q : ndarray, shape (frames, nq)
        Configurations.
    h : ndarray, shape (frames, N)
        The wheels' momenta at those frames [N m s].

    Returns
    -------
    Mark
        ``wheel_momentum``, with a length scale per frame.
    """
    data = model.createData()
    stored = np.empty((len(q), 3))
    bus = np.empty((len(q), 4, 4))
    for k, qk in enumerate(q):
        pin.forwardKinematics(model, data, qk)
        bus[k] = data.oMi[1].homogeneous
        stored[k] = bus[k, :3, :3] @ wheels.momentum_bus(h[k])
    size = np.linalg.norm(stored, axis=1)
    largest = size.max() if len(size) else 0.0
    length = ARROW_LENGTH * size / largest if largest > 0 else np.zeros(len(q))
    places = np.tile(np.eye(4), (len(q), 1, 1))
    for k in range(len(q)):
        u = stored[k] / size[k] if size[k] > 0 else np.array([0.0, 1.0, 0.0])
        places[k, :3, :3] = _y_onto(u)
        places[k, :3, 3] = bus[k, :3, 3] + 0.5 * length[k] * u
    scales = np.ones((len(q), 3))
    scales[:, 1] = np.maximum(length, _HIDDEN)
    shape = mg.Cylinder(1.0, ARROW_RADIUS)
    return Mark(WHEEL_MOMENTUM, shape, mg.MeshLambertMaterial(color=_ARROW_COLOR), places, scales)


def _triad(name: str, placements: np.ndarray) -> Mark:
    return Mark(name, mg.triad(TRIAD_SCALE), None, placements)


def _y_onto(u: np.ndarray) -> np.ndarray:
    """A rotation taking the y axis onto the unit vector u."""
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 1.0, 0.0]), u).matrix()
