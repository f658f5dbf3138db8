"""Attitude representations shared by the robot and model layers.

* :mod:`.mrp`: modified Rodrigues parameters, the paper's spatial attitudes (base and end
  effector), their rotation matrices, quaternions, B(s) and the shadow set.

A leaf package: it imports nothing else of ffsm-pin, so the robot layer (base pose <-> q) and
the model layer (kinematic rows) can both use it.
"""

from . import mrp

__all__ = ["mrp"]
