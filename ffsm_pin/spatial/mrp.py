"""Deprecated location: modified Rodrigues parameters moved to :mod:`ffsm_pin.attitude.mrp`.

Kept as an alias for one release; import ``from ffsm_pin.attitude import mrp`` instead.
"""

from ..attitude.mrp import (  # noqa: F401
    B_matrix,
    L_matrix,
    from_quaternion,
    from_rotation,
    from_rpy,
    shadow,
    skew,
    to_quaternion,
    to_rotation,
)
