"""Cases -> batches: the cases of a campaign that share a robot, run together by one task.

A worker runs the cases of a batch one after the other (:func:`ffsm_pin.sweep.engine.run_batch`)
and loads their robot once (:class:`ffsm_pin.sim.robots.SharedRobots`); each case still has its
own controller, estimates, plant, sensors and random generators, stops on its own, and gives
the outcome its single task gives. :func:`make_batches` groups the cases by their scenario's
``[robot]`` section (the key of the robot they load) and their controller type
(:func:`kernel_key`), the groups of a robot together, and cuts each group, in case order, into
batches of at most ``size`` cases: a batch of one controller type runs its cases in lock-step
as one group (:func:`ffsm_pin.sim.lockstep.lockstep_groups`), where a batch that straddled two
types left a case alone at its cut (a run alone costs about 1.6 times a lock-step case-step).

:func:`default_batch_size` (``--batch-size`` not given, docs/campaigns.md): the fewest cases a
batch that cut the cases to run into at most :data:`BATCHES_PER_WORKER` batches per worker, and
at most :data:`MAX_BATCH` cases a batch. Several batches per worker keep every worker busy to
the end (no worker left with one long batch while the others idle); the cap keeps the grain of
a resume: an interrupted campaign loses the finished cases of its running batches (a batch
returns its rows together), and a killed worker re-runs its batch from its first case.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence

from .cases import Case

__all__ = [
    "BATCHES_PER_WORKER", "MAX_BATCH", "default_batch_size", "kernel_key", "make_batches",
    "robot_key",
]  # fmt: skip

#: Batches per worker the default size aims at.
BATCHES_PER_WORKER = 4
#: Most cases in a batch of the default size.
MAX_BATCH = 8


def default_batch_size(n_cases: int, n_workers: int) -> int:
    """Cases per batch when none is given: ``ceil(n_cases / (BATCHES_PER_WORKER * n_workers))``
    within ``1 .. MAX_BATCH``.

    Parameters
    ----------
    n_cases : int
        Cases to run.
    n_workers : int
        Workers of the cluster (at least one is assumed).

    Returns
    -------
    int
        The batch size.
    """
    per = math.ceil(n_cases / (BATCHES_PER_WORKER * max(1, n_workers)))
    return max(1, min(MAX_BATCH, per))


def robot_key(case: Case) -> Hashable:
    """What the cases of a batch share: the ``[robot]`` section of the case's scenario.

    Parameters
    ----------
    case : Case
        A case.

    Returns
    -------
    Hashable
        Its :class:`~ffsm_pin.scenario.spec.RobotSpec`.
    """
    return case.scenario.robot


def kernel_key(case: Case) -> Hashable:
    """What decides the compiled kernels a case runs: its robot (:func:`robot_key`, whose root
    joint picks the geometry's kernels) and its controller type. A campaign's engine compiles
    (or loads) each key's kernels once before its cases run
    (:func:`ffsm_pin.sweep.engine.run_cases`).

    Parameters
    ----------
    case : Case
        A case.

    Returns
    -------
    Hashable
        ``(robot_key(case), controller type)``.
    """
    return robot_key(case), case.scenario.controller.type


def make_batches(cases: Sequence[Case], size: int) -> list[list[Case]]:
    """The cases grouped by :func:`kernel_key` (robot and controller type), each group cut
    into batches of ``size`` cases.

    Parameters
    ----------
    cases : sequence of Case
        The cases to run.
    size : int
        Most cases in a batch (at least 1).

    Returns
    -------
    list of list of Case
        Every case once; the groups of a robot together, the robots in the order of their
        first case and a robot's groups in the order of theirs, each group in case order.
    """
    robots: dict[Hashable, int] = {}
    groups: dict[Hashable, list[Case]] = {}
    for case in cases:
        robots.setdefault(robot_key(case), len(robots))
        groups.setdefault(kernel_key(case), []).append(case)
    size = max(1, size)
    ordered = sorted(groups.values(), key=lambda g: robots[robot_key(g[0])])  # (stable)
    return [g[i : i + size] for g in ordered for i in range(0, len(g), size)]
