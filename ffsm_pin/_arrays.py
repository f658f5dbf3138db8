"""Small array helpers shared by the layers (model, control)."""

from __future__ import annotations

import numpy as np


def read_only(a) -> np.ndarray:
    """``a`` as an array that cannot be written to (results handed out by the model layer)."""
    a = np.asarray(a)
    a.flags.writeable = False
    return a


def contiguous_rows(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """C-contiguous float copies (where needed) of a block of recorded rows (the arrays a
    compiled kernel takes)."""
    return tuple(np.ascontiguousarray(a, dtype=float) for a in arrays)
