"""Small array helpers shared by the model modules."""

from __future__ import annotations

import numpy as np


def read_only(a) -> np.ndarray:
    """``a`` as an array that cannot be written to (results handed out by the model layer)."""
    a = np.asarray(a)
    a.flags.writeable = False
    return a
