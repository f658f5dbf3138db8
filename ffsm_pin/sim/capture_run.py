"""Capture in the loop (issue 40, second slice): with ``[capture]`` the hand grasps the
``[target]`` when the two grasp frames are within the tolerances, and the run goes on with
the merged robot.

:class:`CaptureMotion` is the loop's hook (:mod:`.loop`): it steps the target with the plant
(its substeps), checks the capture condition once per control period on the TRUE state
(:meth:`~.impact.CaptureModel.ready`) and, at capture, applies the weld impact
(:func:`~.impact.impact`), merges the target into the robot
(:func:`~.impact.merge_after_capture`) and hands the loop a new :class:`~.plant.Plant` for the
merged robot. After capture the target's recorded pose and twist are those of the held body.
:meth:`CaptureMotion.momentum_rows` gives the recorded momentum of the whole system: robot and
target before capture, the merged robot after. :class:`CaptureOutcome` is what the summary
says of the capture. At the grasp it prepares a
:class:`~ffsm_pin.control.held_body.CaptureEvent` (what ``[capture] estimates`` lets the
controller know of the held body), which the loop hands the controller's optional
``on_capture`` before that period's step (:meth:`CaptureMotion.notify`; docs/capture.md,
"The controller after capture").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .._docstrings import fill_doc
from ..control.held_body import CaptureEvent
from ..scenario.target_spec import CaptureSpec
from ._docs import SIM_DOC
from .estimates import body_inertias, perturb_body
from .held_truth import HeldTruth, held_truth, momenta_holding
from .impact import CaptureModel, CaptureTolerances, capture_model, impact, merge_after_capture
from .measurement import Sensor
from .plant import Plant
from .setup import Setup
from .target import Target, TargetState
from .target_run import TargetMotion

#: The summary's keys of a run with ``[capture]`` (and a campaign's results columns).
CAPTURE_KEYS = (
    "captured",
    "capture_time",
    "impact_impulse",
    "relative_speed_at_capture",
    "impact_energy_lost",
)


#: The per-step signals of a run with ``[capture]``: the distance between the two grasp
#: frames' origins [m] and the relative speed of the two bodies at the hand's grasp point
#: [m/s] (:meth:`~.impact.CaptureModel.relative_motion`; at the capture's row, after the
#: impact).
CAPTURE_SIGNALS: dict[str, tuple[int, ...]] = {"grasp_distance": (), "grasp_speed": ()}


@dataclass(frozen=True)
class CaptureOutcome:
    """What happened to the target: captured or not, when, and the impact.

    Attributes
    ----------
    captured : bool
        The hand grasped the target during the run.
    time : float or None
        When [s] (the first control period at which the condition held).
    impulse : tuple of float or None
        The impulse on the hand at its grasp frame, its axes: [N s] linear, [N m s] angular.
    relative_speed : float or None
        The relative speed of the two bodies at the hand's grasp point just before [m/s].
    distance : float or None
        The distance between the two grasp frames' origins then [m].
    energy_lost : float or None
        The kinetic energy the plastic impact took [J].
    tolerance_position, tolerance_velocity : float or None
        The ``[capture]`` tolerances [m], [m/s] (for the figures).
    hand_grasp : tuple of float
        The hand's grasp frame in the end-effector frame, ``hand_xyz`` [m] then ``hand_rpy``
        [rad] (for the replay).
    """

    captured: bool = False
    time: float | None = None
    impulse: tuple[float, ...] | None = None
    relative_speed: float | None = None
    distance: float | None = None
    energy_lost: float | None = None
    tolerance_position: float | None = None
    tolerance_velocity: float | None = None
    hand_grasp: tuple[float, ...] = (0.0,) * 6

    def summary(self) -> dict:
        """The summary.json keys (:data:`CAPTURE_KEYS`).

        Returns
        -------
        dict
            ``captured``, ``capture_time`` [s], ``impact_impulse`` (6 values, [N s], [N m s]),
            ``relative_speed_at_capture`` [m/s], ``impact_energy_lost`` [J]; None but
            ``captured`` without a capture.
        """
        return {
            "captured": self.captured,
            "capture_time": self.time,
            "impact_impulse": None if self.impulse is None else list(self.impulse),
            "relative_speed_at_capture": self.relative_speed,
            "impact_energy_lost": self.energy_lost,
        }


@fill_doc(SIM_DOC)
class CaptureMotion(TargetMotion):
    """The target over a run with ``[capture]``: free until the hand grasps it, then held.

    Parameters
    ----------
    %(target_motion)s
    robot : Robot
        The plant's robot (free-flyer root).
    spec : CaptureSpec
        The ``[capture]`` table.
    substeps : int
        Plant steps per control period: the target is stepped as often.
    perturb : callable or None
        With ``estimates = "perturbed"``: the held body (``pin.Inertia``, end-effector frame)
        -> the controller's estimate of it (:func:`held_body_estimate`); None: as given.
    setup : Setup or None
        The run: with it, the true parameters after the capture (:meth:`held_truth`) and the
        event's ``theta_d_true``; None: neither.
    """

    def __init__(
        self,
        target: Target,
        state: TargetState,
        robot,
        spec: CaptureSpec,
        substeps: int = 1,
        perturb: Callable[[pin.Inertia], pin.Inertia] | None = None,
        setup: Setup | None = None,
    ) -> None:
        super().__init__(target, state)
        self.perturb = perturb
        self.event: CaptureEvent | None = None  # the capture, until the controller is told
        self.capture: CaptureModel = capture_model(robot, target, hand_grasp(spec))
        self.tolerances = CaptureTolerances(spec.tolerance_position, spec.tolerance_velocity)
        self.estimates = spec.estimates
        self.detumble_rate = spec.detumble_rate  # [rad/s], the summary's detumble_time
        self.substeps = max(1, int(substeps))
        self.outcome = CaptureOutcome(
            tolerance_position=spec.tolerance_position,
            tolerance_velocity=spec.tolerance_velocity,
            hand_grasp=(*spec.hand_xyz, *spec.hand_rpy),
        )
        self.relative: tuple[float, float] = (np.nan, np.nan)  # grasp distance, speed now
        self.plant: Plant | None = None  # the merged robot's, after capture
        self._held: pin.SE3 | None = None  # the target frame in the end-effector frame
        self.held: pin.Inertia | None = None  # the held body, end-effector frame (true)
        self.setup = setup
        self.truth: HeldTruth | None = None  # the merged robot's true parameters, once held
        self._grasp: tuple[np.ndarray, np.ndarray] | None = None  # combined q, v after impact

    def advance(self, dt: float) -> None:
        """Step the free target ``dt`` [s] in the plant's substeps (held: nothing to do, its
        state follows the hand, :meth:`at_period`)."""
        if self.plant is None:
            h = dt / self.substeps
            for _ in range(self.substeps):
                self.state = self.free_step(h)

    def at_period(self, t: float, q, v, plant: Plant, sensor: Sensor):
        """The hook of each control period, before the measurement: grasp when the true
        state meets the tolerances; once held, the target's state from the hand's.

        Parameters
        ----------
        t : float
            Time [s].
        q, v : ndarray
            The robot's true state (Pinocchio convention).
        plant : Plant
            The loop's plant.
        sensor : Sensor
            The loop's sensor.

        Returns
        -------
        plant : Plant
            The plant to go on with (the merged robot's from the capture on).
        sensor : Sensor
            The sensor to go on with (the merged robot's with ``estimates = "true"``).
        v : ndarray
            The robot's velocity (after the impact at capture).
        """
        cap = self.capture
        if self.plant is not None:
            self.state = self._held_state(q, v)
            self.relative = cap.relative_motion(*cap.joint_state(q, v, self.state))
            return plant, sensor, v
        qc, vc = cap.joint_state(q, v, self.state)
        distance, speed = self.relative = cap.relative_motion(qc, vc)
        tol = self.tolerances
        if not (distance <= tol.position and speed <= tol.velocity):  # (CaptureModel.ready)
            return plant, sensor, v
        hit = impact(cap, qc, vc)
        robot, q_new, v_new = self._merge(qc, hit.v, plant)
        held = None  # what the controller may know of the held body ([capture] estimates)
        if self.estimates != "unknown":
            held = self.held
            if self.estimates == "perturbed" and self.perturb is not None:
                held = self.perturb(held)
        truth = self.truth
        theta_d_true = None if truth is None else truth.theta_d.copy()
        # the controller is also told the system's v_0, A_0 after the impact: with "true" the
        # truth's, with "perturbed" those of the robot holding the drawn body
        momenta = None
        if truth is not None and self.estimates == "true":
            momenta = truth.momenta
        elif held is not None and self.estimates == "perturbed":
            momenta = momenta_holding(cap.robot, held, q_new, v_new)
        self.event = CaptureEvent(float(t), self.estimates, held, theta_d_true, momenta)
        self.outcome = CaptureOutcome(
            True, float(t), tuple(float(x) for x in hit.impulse), speed, distance,
            float(hit.energy_loss), tol.position, tol.velocity, self.outcome.hand_grasp,
        )  # fmt: skip
        self._grasp = (qc, hit.v)
        if self.estimates == "true":  # a controller measuring M, h sees the merged robot's
            sensor = Sensor(robot, sensor.model, full_model=sensor.full_model)
        return self.plant, sensor, v_new

    def _merge(self, qc, v_after, plant: Plant) -> tuple:
        """Hold the target from the combined state ``qc``, ``v_after`` (after the impact):
        the merged robot's plant, the held body, its state and the true parameters.

        Returns
        -------
        tuple
            The merged robot and its (q, v).
        """
        cap = self.capture
        self.relative = cap.relative_motion(qc, v_after)  # the row's state: after the impact
        known = self.estimates != "unknown"
        robot, q_new, v_new = merge_after_capture(cap, qc, v_after, known=known)
        self.plant = plant.with_robot(robot)  # (with wheels, they stay on the bus)
        self.plant.reset(q_new, v_new)  # the merged system's momentum, kept from now on
        data = cap.model.createData()
        pin.framesForwardKinematics(cap.model, data, qc)
        self._held = data.oMf[cap.robot.ee_frame_id].actInv(data.oMi[cap.target_joint])
        self.state = cap.target_state(qc, v_after)
        self.held = self._held.act(self.target.spatial_inertia())  # (the merged robot's)
        if self.setup is not None:  # (the true parameters from now on)
            self.truth = held_truth(self.setup, self.held, robot, q_new, v_new)
        return robot, q_new, v_new

    def record(self) -> dict:
        """What a spool keeps of the grasp (JSON-able; :meth:`restore` reads it back): the
        outcome and the combined state just after the impact.

        Returns
        -------
        dict
            ``time``, ``impulse``, ``relative_speed``, ``distance``, ``energy_lost``, ``q``,
            ``v``.
        """
        o = self.outcome
        assert self._grasp is not None and o.impulse is not None
        qc, v_after = self._grasp
        return {
            "time": o.time, "impulse": list(o.impulse), "relative_speed": o.relative_speed,
            "distance": o.distance, "energy_lost": o.energy_lost,
            "q": [float(x) for x in qc], "v": [float(x) for x in v_after],
        }  # fmt: skip

    def restore(self, record: Mapping, plant: Plant) -> None:
        """Put the hook in its state after the grasp :meth:`record` described (a run
        recovered from its spool): the same merged robot, plant, held body and outcome.

        Parameters
        ----------
        record : mapping
            :meth:`record`'s dict.
        plant : Plant
            The run's plant before the capture (the loop's: with wheels, theirs).
        """
        qc, v_after = np.asarray(record["q"], float), np.asarray(record["v"], float)
        self._merge(qc, v_after, plant)
        self._grasp = (qc, v_after)
        self.outcome = CaptureOutcome(
            True, float(record["time"]), tuple(float(x) for x in record["impulse"]),
            float(record["relative_speed"]), float(record["distance"]),
            float(record["energy_lost"]), self.tolerances.position, self.tolerances.velocity,
            self.outcome.hand_grasp,
        )  # fmt: skip

    def notify(self, controller) -> None:
        """Hand a capture not yet told to the controller's optional ``on_capture`` (once;
        the loop calls this before each period's step, inside its controller guard).

        Parameters
        ----------
        controller : Controller
            The run's controller.
        """
        if self.event is not None:
            event, self.event = self.event, None
            hook = getattr(controller, "on_capture", None)
            if hook is not None:
                hook(event)

    def write(self, arrays: Mapping[str, np.ndarray], i: int) -> None:
        """Record the target's state and the two grasp frames' relative motion in row ``i``.

        Parameters
        ----------
        arrays : mapping of str to ndarray
            The recorder's columns: :data:`CAPTURE_SIGNALS` and the target's.
        i : int
            The row.
        """
        super().write(arrays, i)
        arrays["grasp_distance"][i], arrays["grasp_speed"][i] = self.relative

    def _held_state(self, q, v) -> TargetState:
        """The held target's state from the merged robot's (q, v)."""
        assert self.plant is not None and self._held is not None
        model, data = self.plant.model, self.plant.data
        fid = self.plant.robot.ee_frame_id
        pin.forwardKinematics(model, data, q, v)
        oMe = pin.updateFramePlacement(model, data, fid)
        twist = self._held.actInv(pin.getFrameVelocity(model, data, fid, pin.LOCAL))
        q_t = pin.SE3ToXYZQUAT(oMe * self._held)
        return TargetState.from_pinocchio(self.target, q_t, twist.vector)

    def momentum_rows(self, block: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The whole system's (P, L) on recorded rows: before the capture the combined
        model's centroidal momentum of robot and target (from ``q``, ``v``, ``target_pose``,
        ``target_twist``), from it on the merged robot's (:meth:`Plant.momentum_rows`).

        Parameters
        ----------
        block : mapping of str to ndarray
            Rows of ``t``, ``q``, ``v``, ``target_pose`` and ``target_twist``.

        Returns
        -------
        P : ndarray, shape (rows, 3)
            Linear momentum, world frame [kg m/s].
        L : ndarray, shape (rows, 3)
            Angular momentum about the system CoM, world frame [kg m^2/s].
        """
        t, q, v = block["t"], block["q"], block["v"]
        n = len(t)
        P, L = np.zeros((n, 3)), np.zeros((n, 3))
        held = np.zeros(n, dtype=bool)
        if self.plant is not None and self.outcome.time is not None:
            held = t >= self.outcome.time  # (the row at capture: the state after the impact)
            if held.any():
                P[held], L[held] = self.plant.momentum_rows(q[held], v[held])
        cap = self.capture
        for i in np.flatnonzero(~held):
            state = TargetState.from_recorded(block["target_pose"][i], block["target_twist"][i])
            h = cap.momentum(*cap.joint_state(q[i], v[i], state))
            P[i], L[i] = h[:3], h[3:]
        return P, L


def target_motions(setup: Setup) -> tuple[TargetMotion | None, CaptureMotion | None]:
    """The loop's target: None without ``[target]``; a :class:`CaptureMotion` (returned
    twice: it is also the capture hook) with ``[capture]``; else a :class:`TargetMotion`.

    Parameters
    ----------
    setup : Setup
        The prepared run (its ``[target]`` and ``[capture]``).

    Returns
    -------
    target : TargetMotion or None
        What the loop steps and records.
    capture : CaptureMotion or None
        The capture hook, None without ``[capture]``.
    """
    spec, sc = setup.scenario.target, setup.scenario
    if setup.target is None or setup.target_state is None or spec is None:
        return None, None
    if spec.capture is None:
        motion: TargetMotion = TargetMotion(setup.target, setup.target_state)
        capture = None
    else:
        capture = CaptureMotion(
            setup.target, setup.target_state, setup.robot, spec.capture, sc.substeps,
            perturb=lambda held: held_body_estimate(held, setup), setup=setup,
        )  # fmt: skip
        motion = capture
    if setup.approach is not None:  # the approach's target sensor reads the true state
        setup.approach.follow(motion, setup.robot)  # (after a capture: the bus-frame hold)
    return motion, capture


def held_body_estimate(held: pin.Inertia, setup: Setup) -> pin.Inertia:
    """The controller's estimate of the held body with ``[capture] estimates = "perturbed"``:
    the body drawn by the ``[controller.estimates]`` rule (:func:`~.estimates.perturb_body`,
    docs/model.md section 6) with its ``spread``, as one more body of the robot's draw: from
    the generator seeded with its ``seed``, after the robot's bodies 0..n (those of
    ``robot.estimated``) are drawn from it. Seeded, reproducible, whatever ``initial`` is.

    Parameters
    ----------
    held : pin.Inertia
        The held body in the end-effector frame.
    setup : Setup
        The prepared run (its ``[controller.estimates]`` and robot).

    Returns
    -------
    pin.Inertia
        The drawn body, end-effector frame.
    """
    est = setup.scenario.controller.estimates
    rng = np.random.default_rng(est.seed)
    for body in body_inertias(setup.robot.estimated):  # the robot's draw (free-flyer)
        perturb_body(body, est.spread, rng)
    return perturb_body(held, est.spread, rng)


def hand_grasp(spec: CaptureSpec) -> pin.SE3:
    """The hand's grasp frame in the end-effector frame (``[capture] hand_xyz``, ``hand_rpy``).

    Parameters
    ----------
    spec : CaptureSpec
        The ``[capture]`` table.

    Returns
    -------
    pin.SE3
        The placement.
    """
    return pin.SE3(pin.rpy.rpyToMatrix(*spec.hand_rpy), np.array(spec.hand_xyz, dtype=float))


def capture_signals(setup: Setup) -> dict[str, tuple[int, ...]]:
    """The recorded per-step signals a run has for its ``[capture]`` (:data:`CAPTURE_SIGNALS`;
    none without one).

    Parameters
    ----------
    setup : Setup
        The prepared run; only its ``[capture]`` is read.

    Returns
    -------
    dict
        Name -> shape of one row.
    """
    spec = setup.scenario.target
    return {} if spec is None or spec.capture is None else CAPTURE_SIGNALS
