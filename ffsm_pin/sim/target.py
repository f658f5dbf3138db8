"""The target of a capture (issue 40): a rigid body that tumbles torque-free until it is grasped.

* :class:`Target`: mass, inertia about the CoM, the CoM and the grasp frame in the target's own
  frame; :meth:`Target.box` builds a uniform box. Bad input is one :class:`ParameterError`
  line.
* :class:`TargetState`: the pose of the target frame in the world, the CoM's velocity (world)
  and the angular velocity (body frame).
* :func:`torque_free_step`: one step of the torque-free motion that keeps the linear momentum
  and the world angular momentum to rounding and the kinetic energy to a bounded O(dt^4)
  error (docs/capture.md, "The torque-free target").

The splitting (McLachlan 1993; Touma & Wisdom 1994; Dullweber, Leimkuhler & McLachlan 1997):
the kinetic energy T = sum_k Pi_k^2 / (2 I_k) in principal axes is a sum of three terms whose
flows are exact rotations about one principal axis each (Pi_k is constant under its own term,
so the body turns at the constant rate Pi_k / I_k about axis k while the body momentum turns
the opposite way). Each such flow keeps the world angular momentum R Pi exactly; their
symmetric (Strang) composition is second order, time-reversible and Poisson, and Yoshida's
triple jump (Phys. Lett. A 150, 1990) makes it fourth order. Being symplectic on an
integrable system, the energy error stays bounded instead of drifting. After each step the
body momentum is reset to R^T L of the step's start, so the world L is kept to one rounding
per step (the projection of :mod:`.plant` in miniature).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pinocchio as pin

from .._arrays import cross3
from ..errors import InertiaError, ParameterError
from ..robot.geometry import check_inertia
from ._target_kernels import torque_free_rotation

# Yoshida's fourth-order triple jump: S(c1 dt) S(c0 dt) S(c1 dt), S a symmetric 2nd-order step
_CBRT2 = 2.0 ** (1.0 / 3.0)
_C1 = 1.0 / (2.0 - _CBRT2)
_C0 = -_CBRT2 * _C1
_ROTATION_TOL = 1e-9  # |R^T R - 1| allowed for a grasp rotation given as a matrix
_INSIDE_TOL = 1e-9  # relative slack of "inside the box" (a grasp frame on a face is inside)


def inertia_matrix(inertia, what: str) -> np.ndarray:
    """A 3x3 inertia [kg m^2] from a 3x3 array or the six numbers (ixx, iyy, izz, ixy, ixz,
    iyz) of the package's tables; anything else is a :class:`ParameterError`.

    Parameters
    ----------
    inertia : array_like
        3x3, or (ixx, iyy, izz, ixy, ixz, iyz).
    what : str
        What it is, for the error message.

    Returns
    -------
    ndarray, shape (3, 3)
        The inertia [kg m^2].
    """
    arr = np.asarray(inertia, dtype=float)
    if arr.shape == (6,):
        xx, yy, zz, xy, xz, yz = arr
        arr = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    if arr.shape != (3, 3):
        raise ParameterError(
            f"{what}.inertia: expected 6 numbers (ixx iyy izz ixy ixz iyz) or a 3x3 matrix, "
            f"got shape {arr.shape}"
        )
    if not np.isfinite(arr).all():
        raise ParameterError(f"{what}.inertia: not finite: {arr.tolist()}")
    return arr


def _vector(value, n: int, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (n,) or not np.isfinite(arr).all():
        raise ParameterError(f"{what}: expected {n} finite numbers, got {np.asarray(value)}")
    return arr


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Target:
    """A rigid target body.

    Attributes
    ----------
    mass : float
        [kg], > 0.
    inertia : ndarray
        3x3 inertia about the CoM, along the target frame's axes [kg m^2]: symmetric positive
        definite and satisfying the triangle inequality of its principal moments (the six
        numbers ixx iyy izz ixy ixz iyz are accepted too).
    grasp : pin.SE3
        The grasp frame in the target frame (``pin.SE3``): the frame the hand welds to.
    com : ndarray
        The CoM in the target frame [m] (a box: its centre, the default).
    size : tuple of 3 float or None
        Full edge lengths of a box centred on the target frame's origin [m], or None (e.g. a
        URDF body). With a size, a grasp frame outside the box (its faces included) is refused.
    name : str
        The name of the target's joint and body in a combined model.
    """

    mass: float
    inertia: np.ndarray
    grasp: pin.SE3 = field(default_factory=pin.SE3.Identity)
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    size: tuple[float, float, float] | None = None
    name: str = "target"

    def __post_init__(self) -> None:
        mass = float(self.mass)
        if not (np.isfinite(mass) and mass > 0):
            raise ParameterError(f"target.mass: {mass} kg; a target needs a positive mass")
        object.__setattr__(self, "mass", mass)
        inertia = inertia_matrix(self.inertia, "target")
        try:
            check_inertia(mass, inertia, "the target")
        except InertiaError as err:  # a URDF error in the loader; here a parameter
            raise ParameterError(f"target.inertia: {err}") from None
        object.__setattr__(self, "inertia", _frozen(inertia))
        object.__setattr__(self, "com", _frozen(_vector(self.com, 3, "target.com")))
        if not isinstance(self.grasp, pin.SE3):
            raise ParameterError(f"target.grasp: expected a pinocchio.SE3, got {self.grasp!r}")
        rot = self.grasp.rotation
        if (
            not np.isfinite(self.grasp.homogeneous).all()
            or np.abs(rot.T @ rot - np.eye(3)).max() > _ROTATION_TOL
            or np.linalg.det(rot) < 0
        ):
            raise ParameterError("target.grasp: the rotation is not a proper rotation matrix")
        object.__setattr__(self, "grasp", pin.SE3(self.grasp))
        if self.size is not None:
            size = _vector(self.size, 3, "target.size")
            if not (size > 0).all():
                raise ParameterError(f"target.size: edges must be > 0, got {size.tolist()} m")
            object.__setattr__(self, "size", tuple(float(s) for s in size))
            half = 0.5 * size
            p = self.grasp.translation
            if (np.abs(p) > half * (1 + _INSIDE_TOL)).any():
                raise ParameterError(
                    f"target.grasp_xyz: {p.tolist()} m is outside the target's box "
                    f"(|x|, |y|, |z| <= {half.tolist()} m)"
                )

    @classmethod
    def box(
        cls,
        size: Sequence[float],
        mass: float,
        inertia=None,
        *,
        grasp_xyz: Sequence[float] = (0.0, 0.0, 0.0),
        grasp_rpy: Sequence[float] = (0.0, 0.0, 0.0),
        name: str = "target",
    ) -> Target:
        """A box of edges ``size`` [m] centred on the target frame, CoM at its centre.

        ``inertia`` (3x3 or ixx iyy izz ixy ixz iyz, about the CoM [kg m^2]) defaults to the
        uniform box's, m/12 (b^2 + c^2, a^2 + c^2, a^2 + b^2). The grasp frame is at
        ``grasp_xyz`` [m] with roll-pitch-yaw ``grasp_rpy`` [rad] in the target frame.

        Parameters
        ----------
        size : sequence of float
            Edges (a, b, c) [m].
        mass : float
            Mass [kg].
        inertia : array_like or None
            About the CoM [kg m^2]; None: the uniform box's.
        grasp_xyz : sequence of float
            Grasp frame origin in the target frame [m].
        grasp_rpy : sequence of float
            Grasp frame roll-pitch-yaw in the target frame [rad].
        name : str
            The target's name.

        Returns
        -------
        Target
            The box.
        """
        a, b, c = _vector(size, 3, "target.size")
        if inertia is None:
            m = float(mass)
            inertia = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * m / 12.0
        xyz = _vector(grasp_xyz, 3, "target.grasp_xyz")
        rpy = _vector(grasp_rpy, 3, "target.grasp_rpy")
        grasp = pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)
        return cls(mass, inertia, grasp=grasp, size=(a, b, c), name=name)

    def spatial_inertia(self) -> pin.Inertia:
        """The target as a Pinocchio inertia expressed in the target frame."""
        return pin.Inertia(self.mass, np.array(self.com), np.array(self.inertia))

    @cached_property
    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """(moments (3,) [kg m^2], axes Q (3x3, columns, a proper rotation)): I = Q diag Q^T."""
        moments, axes = np.linalg.eigh(np.array(self.inertia))
        if np.linalg.det(axes) < 0:
            axes[:, 2] = -axes[:, 2]
        return moments, axes


@dataclass(frozen=True, eq=False)
class TargetState:
    """The target's state.

    Attributes
    ----------
    pose : pin.SE3
        The target frame in the world (``pin.SE3``).
    velocity : ndarray
        The CoM's velocity in the world frame [m/s].
    angular_velocity : ndarray
        The angular velocity in the target (body) frame [rad/s].
    """

    pose: pin.SE3
    velocity: np.ndarray
    angular_velocity: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "pose", pin.SE3(self.pose))
        object.__setattr__(self, "velocity", _frozen(_vector(self.velocity, 3, "velocity")))
        w = _vector(self.angular_velocity, 3, "angular_velocity")
        object.__setattr__(self, "angular_velocity", _frozen(w))

    @classmethod
    def from_rpy(
        cls,
        position: Sequence[float],
        attitude_rpy: Sequence[float],
        velocity: Sequence[float] = (0.0, 0.0, 0.0),
        angular_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> TargetState:
        """From the target frame's origin [m] and roll-pitch-yaw [rad] in the world, the CoM
        velocity (world) [m/s] and the body rates [rad/s].

        Parameters
        ----------
        position : sequence of float
            Target frame origin, world [m].
        attitude_rpy : sequence of float
            Roll-pitch-yaw in the world [rad].
        velocity : sequence of float
            CoM velocity, world [m/s].
        angular_velocity : sequence of float
            Body rates [rad/s].

        Returns
        -------
        TargetState
            The state.
        """
        rpy = _vector(attitude_rpy, 3, "attitude_rpy")
        pose = pin.SE3(pin.rpy.rpyToMatrix(*rpy), _vector(position, 3, "position"))
        return cls(pose, np.asarray(velocity, float), np.asarray(angular_velocity, float))

    def com_position(self, target: Target) -> np.ndarray:
        """The CoM in the world [m]."""
        return self.pose.act(np.array(target.com))

    def linear_momentum(self, target: Target) -> np.ndarray:
        """m v_com, world frame [kg m/s]."""
        return target.mass * self.velocity

    def angular_momentum(self, target: Target, about=None) -> np.ndarray:
        """The angular momentum in the world frame [kg m^2/s]: R I w about the CoM, plus
        (c - p) x m v about the world point ``about`` [m] when it is given.

        Parameters
        ----------
        target : Target
            The body (its mass and inertia).
        about : array_like or None
            World point [m]; None: the CoM.

        Returns
        -------
        ndarray, shape (3,)
            [kg m^2/s], world frame.
        """
        L = self.pose.rotation @ (target.inertia @ self.angular_velocity)
        if about is None:
            return L
        lever = self.com_position(target) - np.asarray(about, dtype=float)
        return L + cross3(lever, self.linear_momentum(target))

    def kinetic_energy(self, target: Target) -> float:
        """``m v.v / 2 + w^T I w / 2`` [J]."""
        w = self.angular_velocity
        return 0.5 * target.mass * float(self.velocity @ self.velocity) + 0.5 * float(
            w @ target.inertia @ w
        )

    def to_pinocchio(self, target: Target) -> tuple[np.ndarray, np.ndarray]:
        """(q (7,), v (6,)) of a free-flyer joint placed at the target frame: q = (p, quaternion
        x y z w), v = the joint frame's twist in its own frame (Pinocchio's convention)."""
        R = self.pose.rotation
        w = self.angular_velocity
        v_origin = R.T @ self.velocity - cross3(w, np.array(target.com))
        return pin.SE3ToXYZQUAT(self.pose), np.concatenate((v_origin, w))

    @classmethod
    def from_recorded(cls, pose, twist) -> TargetState:
        """The state a run's row records (``target_pose``: position and quaternion x, y, z, w;
        ``target_twist``: CoM velocity, then body rates; :class:`~.target_run.TargetMotion`).

        Parameters
        ----------
        pose : array_like, shape (7,)
            The row's ``target_pose``.
        twist : array_like, shape (6,)
            The row's ``target_twist``.

        Returns
        -------
        TargetState
            The state.
        """
        twist = np.asarray(twist, dtype=float)
        return cls(pin.XYZQUATToSE3(np.asarray(pose, dtype=float)), twist[:3], twist[3:])

    @classmethod
    def from_pinocchio(cls, target: Target, q, v) -> TargetState:
        """The inverse of :meth:`to_pinocchio`.

        Parameters
        ----------
        target : Target
            The body.
        q : array_like, shape (7,)
            Free-flyer configuration (position, quaternion).
        v : array_like, shape (6,)
            Free-flyer velocity (Pinocchio convention).

        Returns
        -------
        TargetState
            The state.
        """
        q = _vector(q, 7, "target q")
        v = _vector(v, 6, "target v")
        pose = pin.XYZQUATToSE3(q)
        w = v[3:]
        v_com = pose.rotation @ (v[:3] + cross3(w, np.array(target.com)))
        return cls(pose, v_com, w)


def _axis_rotation(k: int, angle: float) -> np.ndarray:
    """The rotation by ``angle`` [rad] about the k-th coordinate axis."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (k + 1) % 3, (k + 2) % 3
    out = np.eye(3)
    out[i, i] = out[j, j] = c
    out[j, i], out[i, j] = s, -s
    return out


def _on_so3(M: np.ndarray) -> np.ndarray:
    """The rotation nearest to M (M a rotation up to rounding): the polar factor U V^T of its
    SVD. A quaternion's matrix would do as well for the attitude, but its determinant is
    biased (1 + 1.6e-16 on average), which makes L = R I w drift ~1e-16 a step in
    :func:`torque_free_step` without ``momentum``; the polar factor's error is unbiased."""
    u, _, vt = np.linalg.svd(M)
    return u @ vt


def _strang(Rp: np.ndarray, pi: np.ndarray, moments: np.ndarray, h: float) -> None:
    """One symmetric splitting step of size h, in place: flows of T_0 (h/2), T_1 (h/2), T_2
    (h), T_1 (h/2), T_0 (h/2); T_k = pi_k^2 / (2 I_k), pi the principal-frame body momentum
    and Rp the world-from-principal rotation."""
    for k, frac in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        rot = _axis_rotation(k, frac * h * pi[k] / moments[k])
        Rp[:] = Rp @ rot
        pi[:] = rot.T @ pi


def torque_free_step(
    target: Target, state: TargetState, dt: float, momentum=None, *, compiled: bool = True
) -> TargetState:
    """The target's state ``dt`` [s] later, moving without force or torque.

    The CoM moves at its constant velocity; the rotation follows Euler's equations through
    a fourth-order symmetric splitting (module docstring) whose sub-steps are exact rotations.
    The energy is kept to O(dt^4) without drift. The world angular momentum R I w is kept to
    rounding: the body momentum is reset at the end to R^T L, L = ``momentum`` (world,
    about the CoM [kg m^2/s]; default: the state's own). Passing the initial L at every step
    (as :class:`~.plant.Plant` keeps its ``momentum0``) leaves one rounding error in L
    whatever the number of steps; recomputing it from each state lets roundings add up
    (a random walk, ~1e-13 relative after 10^4 steps).

    Parameters
    ----------
    target : Target
        The body.
    state : TargetState
        The state at t.
    dt : float
        Step [s].
    momentum : array_like or None
        World angular momentum about the CoM to keep [kg m^2/s].
    compiled : bool
        The rotation by the compiled kernel (:mod:`._target_kernels`, the same arithmetic;
        the default) or by this numpy reference.

    Returns
    -------
    TargetState
        The state at t + dt.
    """
    dt = float(dt)
    if not (np.isfinite(dt) and dt > 0):
        raise ParameterError(f"torque_free_step: dt must be > 0, got {dt}")
    moments, Q = target.principal
    R0 = state.pose.rotation
    L0 = R0 @ (target.inertia @ state.angular_velocity)  # world angular momentum
    if momentum is not None:
        L0 = _vector(momentum, 3, "torque_free_step: momentum")
    if compiled:
        w0, inertia = state.angular_velocity, target.inertia
        R, w = torque_free_rotation(R0, w0, L0, inertia, moments, Q, dt, _C0, _C1)
    else:
        Rp = R0 @ Q
        pi = Q.T @ (target.inertia @ state.angular_velocity)
        for c in (_C1, _C0, _C1):
            _strang(Rp, pi, moments, c * dt)
        R = _on_so3(Rp @ Q.T)
        w = np.linalg.solve(target.inertia, R.T @ L0)  # I^-1 R^T L0, I as stored
    com = state.com_position(target) + dt * state.velocity
    position = com - R @ np.array(target.com)
    return TargetState(pin.SE3(R, position), state.velocity, w)
