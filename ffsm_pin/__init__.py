"""ffsm-pin: free-floating space manipulators on Pinocchio.

Layers, from the bottom up:

* :mod:`ffsm_pin.robot` loads and validates a planar free-floating robot from URDF;
* :mod:`ffsm_pin.state` computes the paper's reduced quantities from Pinocchio for a state;
* :mod:`ffsm_pin.barycentric` is the parametric model (theta_z, theta_d, theta_b, regressors);
* :mod:`ffsm_pin.control` is the adaptive prescribed-performance controller of Lu & Jia (2019);
* :mod:`ffsm_pin.sim` is the momentum-exact plant, scenarios, runs, figures and replay.
"""

from .errors import FfsmError
from .robot import FreeFloatingRobot, Robot, load_robot, shipped_urdfs

__all__ = ["FfsmError", "FreeFloatingRobot", "Robot", "load_robot", "shipped_urdfs"]
__version__ = "0.1.0"
