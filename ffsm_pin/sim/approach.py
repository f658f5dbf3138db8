"""The approach (issue 40, third slice): the end-effector reference follows the target's grasp
frame, predicted from the target's measured state.

``[approach]`` (:class:`~ffsm_pin.scenario.target_spec.ApproachSpec`): a target sensor
(:class:`TargetSensor`: Gaussian noise on position, attitude, CoM velocity and body rates, and
a delay of whole control periods; what the controller sees, never the plant) measures the
target; :func:`predict` carries the delayed measurement to the present torque-free (constant
CoM velocity, Euler's equations: :func:`~.target.torque_free_step`); :func:`grasp_motion`
gives the grasp frame origin's position, velocity and acceleration from that state. The
reference is the quintic blend, over ``time`` seconds, from the ``[reference]``'s to the
grasp point (less the hand's grasp offset turned by the measured end-effector attitude), and
after a capture it brings the hand, from its measured position and velocity just after the
impact, to rest (:data:`HOLD_TIME`).

How the controller reads it: the controllers evaluate their scenario's
:class:`~ffsm_pin.scenario.spec.Reference` (numpy and compiled alike) through its kernel
arrays, the stored arrays themselves. :class:`Approach` gives the controller a reference from
data whose one polynomial segment it rewrites in place once per control period, before the
controller runs, with the second-order Taylor expansion of the approach reference at that
period's time: the controller evaluates value, rate and (by differentiation) acceleration
there exactly. :class:`ApproachController` is the wrapper that does it (the loop is
unchanged); :meth:`Approach.sample` gives the recorded reference after the run.
docs/capture.md, "The approach".
"""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np
import pinocchio as pin

from .._arrays import cross3
from ..attitude import mrp
from ..scenario.spec import Reference, Scenario
from ..scenario.target_spec import ApproachSpec
from ..scenario.trajectory import ReferenceData
from .hold import BusHold
from .target import Target, TargetState, torque_free_step

#: [s] the time constant with which the reference comes to rest after a capture
HOLD_TIME = 0.5
_FAR = 1e300  # the start of the table's last (never used) segment [s]


class TargetSensor:
    """The target's state as the controller sees it: seeded Gaussian noise, then a delay.

    At control period k with delay d the sensor returns the noisy measurement of period
    max(k - d, 0). Noise per measurement, from one ``numpy.random.default_rng(seed)``
    stream in the order position, attitude, velocity, angular velocity: the target frame's
    position [m]; its attitude turned by exp([n]) on the body side (n a rotation vector
    [rad]); the CoM velocity [m/s]; the body angular velocity [rad/s].

    Parameters
    ----------
    spec : ApproachSpec
        The ``[approach]`` table (``seed``, ``delay``, ``noise``).
    """

    def __init__(self, spec: ApproachSpec) -> None:
        self.sigma = np.repeat(np.asarray(spec.noise, dtype=float), 3)
        self.noisy = bool(np.any(self.sigma > 0))
        self.rng = np.random.default_rng(spec.seed)
        self.buffer: deque[TargetState] = deque(maxlen=spec.delay + 1)

    def observe(self, state: TargetState) -> TargetState:
        """What the controller is given of the true ``state`` at this period.

        Parameters
        ----------
        state : TargetState
            The target's true state now.

        Returns
        -------
        TargetState
            The (noisy) measurement of ``delay`` periods ago (of the first period early on).
        """
        if self.noisy:
            n = self.rng.standard_normal(12) * self.sigma
            pose = pin.SE3(state.pose.rotation @ pin.exp3(n[3:6]), state.pose.translation + n[:3])
            state = TargetState(pose, state.velocity + n[6:9], state.angular_velocity + n[9:])
        self.buffer.append(state)
        return self.buffer[0]


def predict(target: Target, state: TargetState, steps: int, dt: float) -> TargetState:
    """The target's state ``steps`` control periods of ``dt`` [s] after ``state``, torque-free.

    Parameters
    ----------
    target : Target
        The body.
    state : TargetState
        The (measured) state.
    steps : int
        Control periods to predict over (the sensor's delay).
    dt : float
        Control period [s].

    Returns
    -------
    TargetState
        The predicted state.
    """
    for _ in range(steps):
        state = torque_free_step(target, state, dt)
    return state


def grasp_motion(target: Target, state: TargetState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration of the grasp frame's origin, world frame, when the
    target moves torque-free.

    With c the CoM, R the attitude, w the body rates and r = R (g - com) the grasp point from
    the CoM: p = c + r, dp/dt = v_com + W x r and d^2p/dt^2 = A x r + W x (W x r), where
    W = R w and A = R dw/dt, dw/dt = I^-1 ((I w) x w) (Euler's equations without torque).

    Parameters
    ----------
    target : Target
        The body (its inertia, CoM and grasp frame).
    state : TargetState
        Its state.

    Returns
    -------
    p, v, a : ndarray, shape (3,)
        [m], [m/s], [m/s^2].
    """
    R = state.pose.rotation
    w = np.asarray(state.angular_velocity, dtype=float)
    inertia = np.asarray(target.inertia)
    r = R @ (target.grasp.translation - np.asarray(target.com))
    W = R @ w
    A = R @ np.linalg.solve(inertia, cross3(inertia @ w, w))
    p = state.com_position(target) + r
    v = np.asarray(state.velocity, dtype=float) + cross3(W, r)
    a = cross3(A, r) + cross3(W, cross3(W, r))
    return p, v, a


def blend(t: float, duration: float) -> tuple[float, float, float]:
    """The quintic s(t) = 10 u^3 - 15 u^4 + 6 u^5, u = t / duration (1 from u = 1 on), with
    ds/dt and d^2s/dt^2: from 0 to 1 with zero rate and acceleration at both ends.

    Parameters
    ----------
    t : float
        Time [s].
    duration : float
        The blend's duration [s], > 0.

    Returns
    -------
    s, ds, dds : float
        The blend and its first two time derivatives [1, 1/s, 1/s^2].
    """
    u = t / duration
    if u >= 1.0:
        return 1.0, 0.0, 0.0
    u = max(u, 0.0)
    s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
    ds = 30.0 * u * u * (1.0 - u) ** 2 / duration
    dds = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / duration**2
    return s, ds, dds


def hand_offset(r_e, z_e, z_e_dot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hand's grasp point from the end-effector frame's origin, world frame, and its first
    two time derivatives at a constant end-effector angular velocity.

    Parameters
    ----------
    r_e : array_like, shape (3,)
        The hand's grasp point in the end-effector frame [m] (``[capture] hand_xyz``).
    z_e, z_e_dot : ndarray, shape (6,)
        The measured end-effector pose (position, MRP) and its rate.

    Returns
    -------
    r, dr, ddr : ndarray, shape (3,)
        R_e r_e [m], W x r [m/s] and W x (W x r) [m/s^2], W the world angular velocity.
    """
    s, ds = np.asarray(z_e[3:6], dtype=float), np.asarray(z_e_dot[3:6], dtype=float)
    R = mrp.to_rotation(s)
    w_body = 4.0 * mrp.B_matrix(s).T @ ds / (1.0 + s @ s) ** 2  # ds/dt = B(s) w / 4
    W = R @ w_body
    r = R @ np.asarray(r_e, dtype=float)
    return r, cross3(W, r), cross3(W, cross3(W, r))


class Approach:
    """The approach reference of a run: the reference the controller reads, rewritten every
    control period, and its log.

    Parameters
    ----------
    spec : ApproachSpec or None
        The ``[approach]`` table; None for a ``[capture]`` without one: the scenario's
        reference until the grasp, then the post-capture hold (:func:`approach_of`).
    reference : Reference
        The scenario's reference, resolved (absolute): where the blend starts from; its base
        attitude is kept.
    target : Target
        The body whose grasp frame the hand goes to.
    dt : float
        Control period [s].
    duration : float
        The run's duration [s] (the log's length).
    hand_xyz : sequence of float
        The hand's grasp point in the end-effector frame [m] (``[capture] hand_xyz``).
    """

    def __init__(
        self,
        spec: ApproachSpec | None,
        reference: Reference,
        target: Target,
        dt: float,
        duration: float,
        hand_xyz=(0.0, 0.0, 0.0),
    ) -> None:
        self.spec, self.base, self.target, self.dt = spec, reference, target, float(dt)
        self.hand = np.asarray(hand_xyz, dtype=float)
        n = reference.n_components
        zeros = ((0.0,) * n, (0.0,) * n)
        self.reference = Reference(
            (), reference.base_attitude, reference.task, "absolute",
            ReferenceData((0.0, 1.0), zeros, "spline"),
        )  # fmt: skip
        self._table = self.reference.kernel_arrays()[5]  # the stored table, read by the kernels
        assert self._table.shape == (1 + 6 * n, 3)
        steps = int(round(duration / dt)) + 1
        self.log = np.full((steps, 3, n), np.nan)  # per control period: z_d, dz_d, ddz_d
        self.sensor = None if spec is None else TargetSensor(spec)
        self.motion = None  # the loop's target (sim.target_run.TargetMotion), see follow()
        self.bus: BusHold | None = None  # the post-capture hold in the bus frame, see follow()
        self._hold: tuple[float, np.ndarray, np.ndarray] | None = None  # t, p, v at capture
        self._write(0.0, reference.ee_pose(0.0), reference.ee_rate(0.0), reference.ee_accel(0.0))

    def follow(self, motion, robot=None) -> None:
        """Take the target's true state from the loop's ``motion`` (its ``state`` at each
        period; a capture's ``outcome``), see :func:`~.capture_run.target_motions`; with
        ``robot``, hold the hand fixed in the bus frame after a capture (:class:`~.hold.BusHold`),
        else at rest in the inertial frame.

        Parameters
        ----------
        motion : TargetMotion
            The loop's target.
        robot : Robot or None
            The robot (free-flyer), for the post-capture hold in the bus frame.
        """
        self.motion = motion
        self.bus = None if robot is None else BusHold(robot, HOLD_TIME)

    def _write(self, t: float, z, dz, ddz) -> None:
        """The table's segments: the Taylor expansion z + dz tau + ddz tau^2 / 2 about t."""
        n = len(z)
        table = self._table
        table[:] = 0.0
        table[0] = (t, t, _FAR)
        table[1 : 1 + n] = np.asarray(z, dtype=float)[:, None]
        table[1 + n : 1 + 2 * n] = np.asarray(dz, dtype=float)[:, None]
        table[1 + 2 * n : 1 + 3 * n] = 0.5 * np.asarray(ddz, dtype=float)[:, None]

    def target_reference(self, meas) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The end-effector position that puts the hand's grasp point on the target's grasp
        point as predicted from the target sensor, with its rate and acceleration.

        Parameters
        ----------
        meas : Measurement
            What the controller sees now (its end-effector attitude turns the hand offset).

        Returns
        -------
        z, dz, ddz : ndarray, shape (3,)
            [m], [m/s], [m/s^2].
        """
        assert self.motion is not None and self.sensor is not None
        seen = self.sensor.observe(self.motion.state)
        state = predict(self.target, seen, len(self.sensor.buffer) - 1, self.dt)
        p, v, a = grasp_motion(self.target, state)
        if self.hand.any():
            r, dr, ddr = hand_offset(self.hand, meas.z_e, meas.z_e_dot)
            p, v, a = p - r, v - dr, a - ddr
        return p, v, a

    def update(self, meas) -> None:
        """Write the reference of the period starting at ``meas.t`` (before the controller).

        Parameters
        ----------
        meas : Measurement
            What the controller is about to be given.
        """
        t = float(meas.t)
        k = int(round(t / self.dt))
        base = self.base
        r, dr, ddr = base.ee_pose(t), base.ee_rate(t), base.ee_accel(t)
        outcome = getattr(self.motion, "outcome", None)
        if self.motion is None:
            z, dz, ddz = r, dr, ddr
        elif self.spec is None and (outcome is None or not outcome.captured):
            z, dz, ddz = r, dr, ddr  # no [approach]: the scenario's reference until the grasp
        elif outcome is not None and outcome.captured and self.bus is not None:
            z, dz, ddz = self.bus.reference(meas)  # the hand held fixed in the bus frame
        elif outcome is not None and outcome.captured:
            if self._hold is None:  # the hand as measured just after the impact
                n = len(r)
                self._hold = (t, np.array(meas.z_e[:n]), np.array(meas.z_e_dot[:n]))
            t0, p0, v0 = self._hold
            decay = np.exp(-(t - t0) / HOLD_TIME)
            z = p0 + v0 * HOLD_TIME * (1.0 - decay)
            dz, ddz = v0 * decay, -v0 * decay / HOLD_TIME
        else:
            g, dg, ddg = self.target_reference(meas)
            assert self.spec is not None
            s, ds, dds = blend(t, self.spec.time)
            z = r + s * (g - r)
            dz = dr + ds * (g - r) + s * (dg - dr)
            ddz = ddr + dds * (g - r) + 2.0 * ds * (dg - dr) + s * (ddg - ddr)
        if k < len(self.log):
            self.log[k] = z, dz, ddz
        self._write(t, z, dz, ddz)

    def sample(self, ts) -> tuple[np.ndarray, np.ndarray]:
        """The reference the controller was given at the recorded times ``ts`` [s].

        Parameters
        ----------
        ts : ndarray
            Times of control periods [s].

        Returns
        -------
        z_d, dz_d : ndarray, shape (len(ts), n)
            The reference and its rate (NaN for a period the run did not reach).
        """
        k = np.rint(np.asarray(ts, dtype=float) / self.dt).astype(int)
        return self.log[k, 0], self.log[k, 1]

    def wrap(self, controller) -> ApproachController:
        """``controller`` with this reference written before each of its periods.

        Parameters
        ----------
        controller : Controller
            The run's controller, built on :attr:`reference`.

        Returns
        -------
        ApproachController
            The wrapper.
        """
        return ApproachController(controller, self)


def approach_of(scenario: Scenario, reference: Reference, target: Target | None):
    """The run's :class:`Approach` and the scenario its controller is built on.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its reference resolved).
    reference : Reference
        That reference.
    target : Target or None
        The run's target.

    Returns
    -------
    approach : Approach or None
        None without ``[approach]``, unless a ``[capture]`` of a ``"position"`` task: then
        the approach without one (the reference, then the hold in the bus frame).
    scenario : Scenario
        ``scenario`` with the approach's reference (itself without ``[approach]``).
    """
    spec = scenario.target
    if spec is None or target is None:
        return None, scenario
    # without [approach], a [capture] of a position task still gets the post-capture hold in
    # the bus frame: the scenario's reference until the grasp (docs/capture.md)
    hold_only = spec.capture is not None and reference.task == "position"
    if spec.approach is None and not hold_only:
        return None, scenario
    hand = (0.0, 0.0, 0.0) if spec.capture is None else spec.capture.hand_xyz
    approach = Approach(spec.approach, reference, target, scenario.dt, scenario.duration, hand)
    return approach, dataclasses.replace(scenario, reference=approach.reference)


class ApproachController:
    """A controller whose reference is the approach's: :meth:`step` writes it for the
    measurement's time, then runs the controller; every other attribute is the controller's.

    Parameters
    ----------
    inner : Controller
        The controller, built on the approach's reference.
    approach : Approach
        The approach.
    """

    def __init__(self, inner, approach: Approach) -> None:
        self.inner = inner
        self.approach = approach

    def step(self, meas):
        """The controller's reply for ``meas`` (``Controller.step``).

        Parameters
        ----------
        meas : Measurement
            What the controller is given.

        Returns
        -------
        object
            The controller's own reply.
        """
        self.approach.update(meas)
        return self.inner.step(meas)

    def __getattr__(self, name: str):
        return getattr(self.inner, name)
