"""ffsm-pin: free-floating space manipulators on Pinocchio.

Layers, from the bottom up:

* :mod:`ffsm_pin.robot` loads and validates a planar free-floating robot from URDF;
* :mod:`ffsm_pin.state` computes the paper's reduced quantities from Pinocchio for a state;
* :mod:`ffsm_pin.barycentric` is the parametric model (theta_z, theta_d, theta_b, regressors);
* :mod:`ffsm_pin.control` is the adaptive prescribed-performance controller of Lu & Jia (2019);
* :mod:`ffsm_pin.sim` is the momentum-exact plant, scenarios, runs, figures and replay.
"""

import os as _os
from pathlib import Path as _Path


def _numba_cache_dir() -> str | None:
    """One per-user numba cache for this installation, wherever it is run from.

    ``$XDG_CACHE_HOME/ffsm-pin/numba`` (default ``~/.cache/ffsm-pin/numba``); None when the
    folder cannot be created or written (numba then keeps its default, next to the sources).
    """
    base = _os.environ.get("XDG_CACHE_HOME") or _os.path.join(_os.path.expanduser("~"), ".cache")
    folder = _Path(base) / "ffsm-pin" / "numba"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return str(folder) if _os.access(folder, _os.W_OK) else None


if "NUMBA_CACHE_DIR" not in _os.environ:  # before numba is imported; the user's choice wins
    _cache = _numba_cache_dir()
    if _cache is not None:
        _os.environ["NUMBA_CACHE_DIR"] = _cache

from .errors import FfsmError  # noqa: E402
from .robot import FreeFloatingRobot  # noqa: E402, load_robot, shipped_urdfs

__all__ = ["FfsmError", "FreeFloatingRobot", "load_robot", "shipped_urdfs"]
__version__ = "0.1.0"
