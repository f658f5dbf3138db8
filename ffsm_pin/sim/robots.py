"""The robot of a scenario's ``[robot]`` section, loaded anew or from a batch's shared copy.

* :func:`robot_of`: ``load_robot`` with the section's keys (what :func:`~.setup.prepare` does
  by default);
* :class:`SharedRobots`: what a batch of campaign cases (:func:`ffsm_pin.sweep.engine.run_batch`)
  hands to :func:`~.setup.prepare` instead: each distinct section is loaded once (URDF parse,
  Pinocchio model, geometry, the example-robot-data look-up), kept as its pickled bytes, and
  every run gets its OWN copy unpickled from them. No object is shared between runs (a run
  that changed its robot's Pinocchio model in place could not change another run's), and a
  copy equals the loaded robot exactly (pinocchio pickles its models in binary: every double
  bit for bit; tests/sim/test_shared_robots.py).
"""

from __future__ import annotations

import pickle

from ..robot import Robot, load_robot
from ..scenario.spec import RobotSpec

__all__ = ["SharedRobots", "robot_of"]


def robot_of(spec: RobotSpec) -> Robot:
    """The robot of a ``[robot]`` section, loaded from its URDF.

    Parameters
    ----------
    spec : RobotSpec
        The scenario's robot section.

    Returns
    -------
    Robot
        The validated robot (:func:`ffsm_pin.robot.load_robot`).
    """
    options = {}
    if spec.base == "free-flyer":
        options = {"locked_joints": dict(spec.locked_joints) or None, "satellite": spec.satellite}
    return load_robot(
        spec.urdf,
        spec.end_effector,
        base=spec.base,
        relative_to=spec.relative_to,
        payload=spec.payload,
        **options,
    )


class SharedRobots:
    """Robots loaded once per distinct ``[robot]`` section; each call returns a fresh copy.

    A section that fails to load is not kept: every run of it raises the same error as a
    single run would. Warnings of a load (a repaired URDF) are given by its first run only.

    Attributes
    ----------
    loads : int
        How many sections were loaded from their URDF (the rest were copies).
    """

    def __init__(self) -> None:
        self._pickled: dict[RobotSpec, bytes] = {}
        self.loads = 0

    def __call__(self, spec: RobotSpec) -> Robot:
        """A copy of the robot of ``spec``, loaded on the first call for it.

        Parameters
        ----------
        spec : RobotSpec
            The scenario's robot section (hashable: the key).

        Returns
        -------
        Robot
            A robot no other call returns.
        """
        data = self._pickled.get(spec)
        if data is None:
            data = pickle.dumps(robot_of(spec), protocol=pickle.HIGHEST_PROTOCOL)
            self._pickled[spec] = data
            self.loads += 1
        robot = pickle.loads(data)  # noqa: S301 - our own bytes, made just above
        assert isinstance(robot, Robot)
        return robot
