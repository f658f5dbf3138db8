"""``detumble_time`` of a run with ``[capture]`` (issue 40; docs/capture.md, "Detumble time"):
from when on the held target's angular velocity relative to the bus stays below
:data:`DETUMBLE_RATE`.

The target's world angular velocity is R_t w_t (``target_pose``'s quaternion, ``target_twist``'s
body rates), the bus's the recorded ``w[:3]`` (inertial frame); their difference is the rate at
which the target turns as seen from the bus. :func:`detumble_outcome` reads the recorded rows
from the capture on, a block at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..scenario.target_spec import DETUMBLE_RATE

_KEYS = ["t", "w", "target_pose", "target_twist"]


@dataclass(frozen=True)
class DetumbleOutcome:
    """The summary's ``detumble_time``.

    Attributes
    ----------
    time : float or None
        The first recorded time [s] from which on (to the run's last row) the target's rate
        relative to the bus stays below :data:`DETUMBLE_RATE`; None when not captured or
        not by the end.
    """

    time: float | None

    def summary(self) -> dict:
        """The summary.json key.

        Returns
        -------
        dict
            ``detumble_time`` [s] or None.
        """
        return {"detumble_time": self.time}


def relative_rate(block: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per row, the norm of R_t w_t - w_b: the target's rate relative to the bus [rad/s].

    Parameters
    ----------
    block : mapping of str to ndarray
        Rows of ``w`` (bus rate first, inertial frame), ``target_pose`` (position, quaternion
        x, y, z, w) and ``target_twist`` (CoM velocity, body rates).

    Returns
    -------
    ndarray, shape (rows,)
        The relative rate [rad/s].
    """
    poses, twists = block["target_pose"], block["target_twist"]
    world = [
        pin.Quaternion(p[6], p[3], p[4], p[5]).normalized().matrix() @ tw[3:]
        for p, tw in zip(poses, twists, strict=True)
    ]
    return np.linalg.norm(np.reshape(world, (-1, 3)) - block["w"][:, :3], axis=1)


def detumble_outcome(
    blocks: Callable[[list[str]], Iterator[Mapping[str, np.ndarray]]],
    capture_time: float | None,
    rate: float = DETUMBLE_RATE,
) -> DetumbleOutcome:
    """When the held target stops turning relative to the bus, for good.

    Parameters
    ----------
    blocks : callable
        keys -> consecutive row blocks of the recorded signals
        (:meth:`~.result.RunResult.signals_blocks`).
    capture_time : float or None
        When the hand grasped the target [s]; None: no capture.
    rate : float
        The tolerance [rad/s].

    Returns
    -------
    DetumbleOutcome
        The time, or None.
    """
    if capture_time is None:
        return DetumbleOutcome(None)
    last_t, after = None, None  # the last row's time; the time of the row after the last fast one
    pending = True  # (the first held row starts a candidate)
    for block in blocks(_KEYS):
        t = np.asarray(block["t"])
        held = t >= capture_time
        if not held.any():
            continue
        t = t[held]
        fast = relative_rate({k: np.asarray(block[k])[held] for k in _KEYS[1:]}) >= rate
        if pending:
            after, pending = float(t[0]), False
        if fast.any():
            i = int(np.flatnonzero(fast)[-1])
            after = float(t[i + 1]) if i + 1 < len(t) else None
        elif after is None:  # the previous block ended fast: this block's first row
            after = float(t[0])
        last_t = float(t[-1])
    return DetumbleOutcome(None if last_t is None else after)
