"""Small array helpers shared by the layers (model, control)."""

from __future__ import annotations

import numpy as np


def read_only(a) -> np.ndarray:
    """``a`` as an array that cannot be written to (results handed out by the model layer)."""
    a = np.asarray(a)
    a.flags.writeable = False
    return a


def read_only_view(a: np.ndarray) -> np.ndarray:
    """``a`` itself when it cannot be written to, else a read-only view of it (``a`` stays
    writeable). A compiled kernel types a read-only array apart from a writeable one, so an
    argument passed both ways would be compiled (or loaded from the cache) twice: as this
    view, it is always the read-only kind the model layer hands out."""
    if not a.flags.writeable:
        return a
    view = a.view()
    view.flags.writeable = False
    return view


def contiguous_rows(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """C-contiguous float copies (where needed) of a block of recorded rows (the arrays a
    compiled kernel takes)."""
    return tuple(np.ascontiguousarray(a, dtype=float) for a in arrays)


def cross3(a, b) -> np.ndarray:
    """The cross product of two 3-vectors: ``np.cross(a, b)``'s value, bit for bit (the same
    products and differences in the same order), without its cost for one pair (~10 us)."""
    a1, a2, a3 = a
    b1, b2, b3 = b
    return np.array((a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1))
