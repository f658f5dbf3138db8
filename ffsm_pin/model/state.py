"""The paper's reduced quantities for one plant state, from Pinocchio's algorithms.

One class for both roots: :class:`State` owns a Pinocchio ``Data`` and computes everything for a
state in one :meth:`State.update` call; the results are read-only arrays. How they are computed
depends on the root joint only, so the work is done by one of two modules, picked from
:data:`FILLERS` by ``robot.base``:

* planar root (:mod:`._state_planar`, docs/model.md section 1): q = (x, y, cos q_b, sin q_b,
  q_m), v = (v_x, v_y, w_b, w_m) with (v_x, v_y) in the base frame; w = (w_b, w_m);
* free-flyer root (:mod:`._state_spatial`, docs/spatial.md section 1): q = (x, y, z, qx, qy,
  qz, qw, q_m), v = (v_B, w_B, dq_m) in the base frame; w = (R_0 w_B, dq_m), w_b inertial.

Every state has: ``M``, ``h`` = C(q, w) w (Eqs. 9a, 8), ``H_bb``, ``H_bm`` (Eq. 13), ``J_b``,
``J_m`` (Eq. 3), ``mass_matrix``, ``nonlinear_effects``, ``centroidal_map``,
``linear_momentum``, ``angular_momentum``, ``com_position``, ``com_velocity`` (v_0),
``base_attitude`` (q_b), ``ee_pose`` (z_e), ``w``, ``base_twist_world``. Free-flyer states add
``M_bb_dot``, ``L_b`` (Eq. 1), ``base_rotation``, ``ee_rotation``, ``ee_angular_jacobian`` and
``base_velocity_world``.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from .._arrays import read_only
from .._docstrings import doc_entries, fill_doc
from ..errors import ParameterError
from ..robot import Robot
from . import _state_planar, _state_spatial

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    q="""
        q : ndarray, shape (nq,)
            Configuration in Pinocchio's convention.""",
    v="""
        v : ndarray, shape (nv,)
            Velocity in Pinocchio's convention.""",
    returns_state="""
        Returns
        -------
        State
            This state, updated.""",
    params_q_v=("q", "v"),
)

#: the module that computes a state, by root joint
FILLERS: dict[str, ModuleType] = {"planar": _state_planar, "free-flyer": _state_spatial}


@fill_doc(_DOC)
class State:
    """Reduced CoM-frame dynamics and kinematics of a free-floating robot at (q, v).

    Sizes: n joints; m2, m3 = 2, 1 (planar) or 3, 3 (free-flyer); nw = m3 + n (the size of
    w); nv = Pinocchio's velocity size (planar 3 + n, free-flyer 6 + n). The inertial frame
    is the world frame of the URDF; "about the CoM" is the whole system's centre of mass.
    Every array is read-only and is set by :meth:`update` (:meth:`update_dynamics`: ``M``,
    ``h``, ``mass_matrix``, ``nonlinear_effects`` only; :meth:`update_kinematics`: ``H_bb``,
    ``H_bm``, ``J_b``, ``J_m`` only).

    Parameters
    ----------
    robot : Robot
        A loaded :class:`~ffsm_pin.robot.Robot` (planar or free-flyer root).

    Attributes
    ----------
    M : ndarray, shape (nw, nw)
        The reduced inertia matrix of Eq. (9a) in w, translation eliminated through the
        conserved linear momentum [kg m^2]; symmetric positive definite.
    h : ndarray, shape (nw,)
        C(q, w) w of Eq. (8), so that ``M dw/dt + h = (0, u_m)`` [N m].
    mass_matrix : ndarray, shape (nv, nv)
        Pinocchio's CRBA matrix in Pinocchio's velocities (base twist in the base frame).
    nonlinear_effects : ndarray, shape (nv,)
        Pinocchio's RNEA(q, v, 0) in Pinocchio's velocities [N, N m].
    H_bb : ndarray, shape (m3, m3)
        Base block of the angular momentum about the CoM, Eq. (13), inertial frame [kg m^2].
    H_bm : ndarray, shape (m3, n)
        Manipulator block of the same, Eq. (13): ``H_bb w_b + H_bm w_m = A_0`` [kg m^2].
    J_b : ndarray, shape (m2 + m3, m3)
        Eq. (3): the end-effector rates (position relative to the CoM [m/s], inertial frame;
        then the attitude rate: planar the angle [rad/s], spatial the MRP rate [1/s]) per
        unit of base angular velocity w_b [rad/s].
    J_m : ndarray, shape (m2 + m3, n)
        Eq. (3): the same per unit of joint rate [rad/s or m/s].
    centroidal_map : ndarray, shape (6, nv)
        Pinocchio's centroidal momentum matrix A_g: (P, L about the CoM) = A_g v, inertial
        frame.
    linear_momentum : ndarray, shape (m2,) planar, (3,) free-flyer
        P, inertial frame [kg m/s].
    angular_momentum : float (planar) or ndarray, shape (3,)
        L = A_0 about the CoM, inertial frame [kg m^2/s].
    com_position : ndarray, shape (2,) planar, (3,) free-flyer
        The system CoM in the inertial frame [m].
    com_velocity : ndarray, same shape
        v_0 = P / m [m/s].
    base_attitude : float (planar) or ndarray, shape (3,)
        q_b: planar the base angle in (-pi, pi] [rad]; spatial the base's MRP, base to
        inertial, ``|q_b| <= 1`` (docs/spatial.md).
    ee_pose : ndarray, shape (m2 + m3,)
        z_e = (p_e, q_e): end-effector position in the inertial frame [m], then its angle
        [rad] (planar) or MRP (spatial).
    w : ndarray, shape (nw,)
        The paper's velocity (w_b, w_m): base angular velocity in the inertial frame and joint
        rates [rad/s].
    base_twist_world : ndarray, shape (3,) planar, (6,) free-flyer
        The base origin's linear velocity [m/s] and the base angular velocity [rad/s], both in
        the inertial frame.
    M_bb_dot : ndarray, shape (3, 3)
        Free-flyer only: d H_bb / dt [kg m^2/s], for the reaction torque F_r of Eq. (7).
    L_b : ndarray, shape (3, 3)
        Free-flyer only: Eq. (1), d q_b / dt = L_b w_b [1/rad].
    base_rotation : ndarray, shape (3, 3)
        Free-flyer only: R_0, base to inertial.
    ee_rotation : ndarray, shape (3, 3)
        Free-flyer only: R_e, end-effector frame to inertial.
    ee_angular_jacobian : ndarray, shape (3, nw)
        Free-flyer only: the end-effector angular velocity in the inertial frame per unit of
        w [rad/s per rad/s].
    base_velocity_world : ndarray, shape (3,)
        Free-flyer only: the base origin's velocity in the inertial frame [m/s].
    """

    # set by update() (update_dynamics(): the first four only); read-only arrays
    M: np.ndarray  # Eq. (9a) [kg m^2]
    h: np.ndarray  # C(q, w) w, Eq. (8) [N m]
    mass_matrix: np.ndarray  # Pinocchio's CRBA matrix (nv x nv)
    nonlinear_effects: np.ndarray  # Pinocchio's RNEA(q, v, 0)
    H_bb: np.ndarray  # Eq. (13)
    H_bm: np.ndarray
    J_b: np.ndarray  # Eq. (3)
    J_m: np.ndarray
    centroidal_map: np.ndarray
    linear_momentum: np.ndarray  # P [kg m/s]
    angular_momentum: float | np.ndarray  # L about the CoM: planar a number [kg m^2/s]
    com_position: np.ndarray  # [m]
    com_velocity: np.ndarray  # v_0 [m/s]
    base_attitude: float | np.ndarray  # q_b: planar angle [rad], spatial MRP
    ee_pose: np.ndarray  # z_e
    w: np.ndarray  # (w_b, w_m) [rad/s]
    base_twist_world: np.ndarray
    # free-flyer root only
    M_bb_dot: np.ndarray
    L_b: np.ndarray  # Eq. (1)
    base_rotation: np.ndarray
    ee_rotation: np.ndarray
    ee_angular_jacobian: np.ndarray
    base_velocity_world: np.ndarray

    def __init__(self, robot: Robot):
        self.robot = robot
        self.model = robot.model
        self.data = self.model.createData()
        self.n_joints = robot.n_joints
        self.total_mass = robot.geometry.total_mass
        self.ee_frame_id = robot.ee_frame_id
        self.lower_triangle = np.tril_indices(self.model.nv, -1)
        self.q: np.ndarray | None = None
        self.v: np.ndarray | None = None
        self._filler = FILLERS[robot.base]

    def update(self, q, v) -> State:
        """Compute every quantity for the plant state (q, v) in Pinocchio conventions.

        %(params_q_v)s

        %(returns_state)s
        """
        self._filler.fill(self, *self._store(q, v))
        return self

    def update_dynamics(self, q, v) -> State:
        """Compute only ``M``, ``h`` (Eqs. 9a, 8), ``mass_matrix`` and ``nonlinear_effects``
        for the plant state (q, v), the same numbers :meth:`update` gives; every other
        quantity keeps the value of an earlier :meth:`update`. What a controller given the
        true model needs each period, at a fraction of the cost.

        %(params_q_v)s

        %(returns_state)s
        """
        self._filler.fill_dynamics(self, *self._store(q, v))
        return self

    def update_kinematics(self, q, v) -> State:
        """Compute only ``H_bb``, ``H_bm`` (Eq. 13), ``J_b`` and ``J_m`` (Eq. 3) for the plant
        state (q, v), the same numbers :meth:`update` gives; every other quantity keeps the
        value of an earlier :meth:`update`. What the generalized Jacobian of a recorded state
        needs (:func:`ffsm_pin.sweep.explain.min_sigma_gjm`), without the dynamics.

        %(params_q_v)s

        %(returns_state)s
        """
        self._filler.fill_kinematics(self, *self._store(q, v))
        return self

    def _store(self, q, v) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) as float arrays of the model's sizes (checked), kept read-only as
        ``self.q``, ``self.v``."""
        model = self.model
        q = np.array(q, dtype=float)
        v = np.array(v, dtype=float)
        if q.shape != (model.nq,) or v.shape != (model.nv,):
            raise ValueError(
                f"state shapes must be q ({model.nq},) and v ({model.nv},), "
                f"got {q.shape} and {v.shape}"
            )
        self.q, self.v = read_only(q), read_only(v)
        return q, v

    @property
    def joint_angles(self) -> np.ndarray:
        """q_m [rad] of the last :meth:`update`."""
        if self.q is None:
            raise ParameterError("State.joint_angles: call update(q, v) first")
        return self.q[self.robot.root.nq :]

    def generalized_jacobian(self, rows: int | None = None) -> np.ndarray:
        """J* = J_m - J_b H_bb^-1 H_bm: the end-effector rates per joint rate when the base
        moves only as the zero-momentum reaction of Eq. (13), ``w_b = -H_bb^-1 H_bm w_m``
        (the generalized Jacobian), at the last :meth:`update` ([m] per [rad] in the position
        rows).

        Parameters
        ----------
        rows : int, optional
            Only the first ``rows`` task rows (default: all m2 + m3).

        Returns
        -------
        ndarray, shape (rows, n)
            J*.
        """
        J_b, J_m = np.asarray(self.J_b)[:rows], np.asarray(self.J_m)[:rows]
        return J_m - J_b @ np.linalg.solve(self.H_bb, self.H_bm)

    def acceleration_to_w_dot(self, a) -> np.ndarray:
        """dw/dt = (dw_b/dt, ddq_m) [rad/s^2] from Pinocchio's acceleration ``a``."""
        return self._filler.w_dot(self, np.asarray(a, dtype=float))

    def reaction_torque(self, w_dot) -> np.ndarray:
        """F_r of Eq. (7), the manipulator's reaction torque on the base (m3,) [N m], for an
        acceleration ``w_dot = (dw_b/dt, ddq_m)`` [rad/s^2] at this state."""
        return self._filler.state_reaction_torque(self, np.asarray(w_dot, dtype=float))
