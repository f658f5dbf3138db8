"""The one interface every controller implements: the paper's, a baseline, a user's.

The run loop (:mod:`ffsm_pin.sim.loop`) knows nothing of a controller's insides. It builds the
controller once from a :class:`ControllerContext`, then calls :meth:`Controller.step` once per
control period with what the sensors report (:class:`Measurement`) and gets joint torques back,
optionally with named signals to record. docs/controllers.md is the user's description.

A controller is any class with

* ``__init__(self, ctx: ControllerContext)``;
* ``step(self, meas: Measurement)`` returning the joint torques ``u_m`` (n_joints,) [N m], or
  ``(u_m, {"name": value, ...})`` to record signals with it.

and optionally the attributes

* ``needs_funnels`` (bool, default False): the controller uses the run's funnels itself
  (``ctx.scenario.performance``; the paper's transformation); a run whose initial errors are
  not strictly inside them is refused before it starts.
* ``params_keys`` (collection of str): the ``[controller.params]`` keys it accepts; any other
  is bad input before the controller is built (one line naming the key and the valid ones).
  Without it the table is handed over unchecked.
* ``scheme`` (str): the controller's variant, reported as ``scheme`` in summary.json (the
  paper's controller: its scheme); the run loop asks the controller, it names none.
* ``sigma_measure`` (str): the matrix whose smallest singular value its ``sigma_min`` signal
  is (``min_sigma_of`` in summary.json).
* ``needs_estimates`` (bool, default False): ``[controller.estimates]`` are drawn and checked
  while the run is prepared (else when ``ctx.estimates`` is first read);
* ``needs_dynamics`` (bool, default False): ``meas.M`` and ``meas.h`` carry the true reduced
  inertia M(q) and C(q, w) w (a known-model baseline); otherwise they are None.
* ``events`` (list of str): notes for the run's summary (for example a singularity warning).
* ``check_task(scenario, n_joints, n_task, m3)`` (static): raise
  :class:`~ffsm_pin.errors.FfsmError` to refuse a scenario before anything is built (too few
  joints for the task, say);
* ``singular_value(meas)``: the distance to a kinematic singularity [m], for ``--check``;
* ``signal_shapes`` (dict name -> shape): the shapes of the signals ``step`` returns, used to
  size the recording before the run; signals not listed are found at the first step.
* ``on_capture(event)``: called once, in a run with ``[capture]``, at the control period of
  the grasp, before that period's ``step``, with a
  :class:`~ffsm_pin.control.held_body.CaptureEvent` (time, and the held body's inertia as
  ``[capture] estimates`` allows); a controller without it runs on unaware of the capture.
* ``signal_layout`` (:class:`SignalLayout`): the signals ``step`` returns as rows of it
  (:class:`SignalRow`); the recorder holds their columns side by side and copies each such
  row in one piece instead of a signal at a time (the paper's controller does,
  :class:`~ffsm_pin.control.lu_jia.LuJiaController`). Its shapes count as declared.

Signals named in :data:`STANDARD_SIGNALS` keep their names in ``trajectory.npz`` (the figures
and the summary know them); any other name is saved as ``ctrl_<name>``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

from ..errors import ParameterError

if TYPE_CHECKING:  # for the annotations only: the scenario is a layer above the controllers
    from ..model import ReducedModel
    from ..robot import Robot
    from ..scenario.spec import Scenario

# Signals a controller may report under their own names (units in docs/cli.md):
STANDARD_SIGNALS = {
    "w_mc": "kinematic-level command, Eqs. (25)+(36) or (81) [rad/s]",
    "w_hat": "filter state w-hat, Eq. (46) [rad/s]",
    "w_tilde": "w - w-hat [rad/s]",
    "e": "M w~ + Y_df (theta_d - theta_d-hat), Eq. (54), with the true M and theta_d",
    "theta_z_hat": "estimate of theta_z, Eq. (42)",
    "theta_d_hat": "estimate of theta_d, Eq. (51)",
    "theta_b_hat": "estimate of theta_b, Eq. (28)",
    "sigma_min": "smallest singular value of the inverted task Jacobian [m]",
    "damping": "lambda^2 of a damped pseudo-inverse (0 = undamped)",
}
USER_SIGNAL_PREFIX = "ctrl_"


class Measurement(NamedTuple):
    """What a controller is given at time t (noise and delay included when configured)."""

    t: float  # [s]
    q_b: float | np.ndarray  # base attitude: planar angle, continuous [rad]; spatial MRP (3)
    q_m: np.ndarray  # joint angles [rad]
    w: np.ndarray  # (w_b, w_m), w_b inertial (m3) [rad/s]
    z_e: np.ndarray  # end-effector pose (p_e, q_e) [m, rad (continuous) or MRP]
    z_e_dot: np.ndarray  # its rate (dp_e/dt, dq_e/dt) [m/s, rad/s or 1/s]
    M: np.ndarray | None = None  # true reduced inertia (controllers with needs_dynamics)
    h: np.ndarray | None = None  # true C(q, w) w (controllers with needs_dynamics)


class ReferenceSample(NamedTuple):
    """The end-effector reference at one time, task-size arrays."""

    z_d: np.ndarray  # z_e,d(t) [m, rad or MRP]
    dz_d: np.ndarray  # its first time derivative
    ddz_d: np.ndarray  # its second time derivative


@dataclass(frozen=True)
class ControllerContext:
    """Everything a controller may use, handed to its constructor once before the run.

    Attributes
    ----------
    n_joints, m2, m3 : int
        Manipulator joints; position and attitude sizes (planar 2, 1; spatial 3, 3).
    task : str
        ``"pose"`` (m2 + m3 components) or ``"position"`` (m2).
    n_task : int
        Components of the end-effector task.
    dt : float
        Control period [s] (the plant may take several steps per period).
    params : mapping
        The scenario's ``[controller.params]`` table.
    reference : callable
        ``reference(t)`` -> :class:`ReferenceSample` (z_d, dz_d, ddz_d) at time t [s].
    base_attitude_reference : ndarray
        Desired base attitude q_b,d (m3,) [rad or MRP].
    robot : Robot
        The loaded robot (``robot.model`` is Pinocchio's model, ``robot.joint_names``).
    model : ReducedModel
        The reduced model (the paper's M, C w, H_bb, H_bm, J_b, J_m, barycentric regressors).
    initial : Measurement
        The exact measurement at t = 0.
    scenario : Scenario
        The whole scenario: ``scenario.performance`` is what the run is judged by (the
        funnels and the singularity threshold, :class:`~ffsm_pin.scenario.spec.Performance`),
        ``scenario.controller.lu_jia`` the paper's controller's own parameters (which another
        controller may read where it uses them).
    estimates_source : callable or None
        What draws the estimates (:attr:`estimates`); None: the run has none.
    estimates : tuple of ndarray or None
        Initial parameter estimates (theta_z, theta_d, theta_b) from ``[controller.estimates]``,
        drawn when first read (a scenario's estimates matter only to a controller that reads
        them; an unusable ``[controller.estimates]`` raises here).
    truth : tuple of ndarray or None
        The true parameters (theta_z, theta_d, theta_b): for diagnostics and known-model
        baselines only; an adaptive controller must not use them in its law.
    torque_limit : ndarray or None
        The actuators' torque limit of each joint (n_joints,) [N m], inf where none
        (``[actuators] torque_limit``), for a law that accounts for it
        (``controller.saturation``); None: not given (no limits).
    """

    n_joints: int
    m2: int
    m3: int
    task: str
    n_task: int
    dt: float
    params: Mapping[str, Any]
    reference: Callable[[float], ReferenceSample]
    base_attitude_reference: np.ndarray
    robot: Robot
    model: ReducedModel
    initial: Measurement
    scenario: Scenario
    estimates_source: Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None
    truth: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    torque_limit: np.ndarray | None = None

    def required_estimates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:attr:`estimates`, for a controller that cannot run without them."""
        est = self.estimates
        if est is None:
            raise ParameterError("this controller needs initial estimates ([controller.estimates])")
        return est

    @property
    def estimates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(theta_z, theta_d, theta_b)-hat at t = 0, or None when the run has none."""
        if self.estimates_source is None:
            return None
        cache = self.__dict__.setdefault("_estimates_cache", [])
        if not cache:
            cache.append(self.estimates_source())
        return cache[0]


@runtime_checkable
class Controller(Protocol):
    """A controller: built from a :class:`ControllerContext`, stepped once per period."""

    def step(self, meas: Measurement) -> Any:
        """Joint torques u_m (n_joints,) [N m] for the period starting at ``meas.t``, or
        ``(u_m, signals)`` with ``signals`` a mapping of names to numbers or arrays."""
        ...


@dataclass(frozen=True, eq=False)
class SignalLayout:
    """Where each signal of a :class:`SignalRow` lies in its flat row: the signals in the
    order of ``shapes``, each taking ``prod(shape)`` consecutive entries (a number one).

    A controller makes its layout once and declares it as ``signal_layout``; the run loop
    compares layouts by identity (a row of that layout object is copied whole into the
    recording).

    Attributes
    ----------
    shapes : mapping of str to tuple of int
        Name -> shape of every signal, in row order.
    slots : mapping of str to tuple
        Name -> (start, stop, shape) of its entries in the row.
    size : int
        Entries of a row.
    """

    shapes: Mapping[str, tuple[int, ...]]
    slots: Mapping[str, tuple[int, int, tuple[int, ...]]] = field(init=False, repr=False)
    size: int = field(init=False)

    def __post_init__(self) -> None:
        shapes = {str(k): tuple(int(d) for d in s) for k, s in self.shapes.items()}
        slots, start = {}, 0
        for key, shape in shapes.items():
            stop = start + math.prod(shape)
            slots[key] = (start, stop, shape)
            start = stop
        object.__setattr__(self, "shapes", shapes)
        object.__setattr__(self, "slots", slots)
        object.__setattr__(self, "size", start)

    def index(self, key: str) -> int | slice:
        """The entries of signal ``key`` in a row: an index for a number, else a slice."""
        start, stop, shape = self.slots[key]
        return start if shape == () else slice(start, stop)


class SignalRow(Mapping[str, Any]):
    """A controller's signals as one flat float row laid out by a :class:`SignalLayout`.

    Reads as the mapping name -> value (a view of the row reshaped to the signal's shape; a
    numpy number, a copy, for shape ``()``), so it is returned where a dict of signals
    would be. The run loop records a row of the controller's declared ``signal_layout``
    whole, after checking its length, and any other row signal by signal; a row that does
    not fit its layout stops the run.

    Parameters
    ----------
    row : ndarray
        The values, shape ``(layout.size,)``; the row is not copied, so a controller makes a
        new one every period.
    layout : SignalLayout
        Its layout.
    """

    __slots__ = ("layout", "row")

    def __init__(self, row: np.ndarray, layout: SignalLayout):
        self.row = row
        self.layout = layout

    def __getitem__(self, key: str) -> Any:
        start, stop, shape = self.layout.slots[key]
        return self.row[start] if shape == () else self.row[start:stop].reshape(shape)

    def __iter__(self) -> Iterator[str]:
        return iter(self.layout.slots)

    def __len__(self) -> int:
        return len(self.layout.slots)


class Reply(NamedTuple):
    """A controller's answer for one period, normalised by :func:`split_reply`."""

    u_m: Any
    signals: Mapping[str, Any]


_NO_SIGNALS: Mapping[str, Any] = {}


def split_reply(reply: Any) -> Reply:
    """``u_m`` or ``(u_m, signals)`` -> :class:`Reply` (no checks on u_m)."""
    if type(reply) is tuple and len(reply) == 2 and type(reply[1]) is SignalRow:
        return Reply(*reply)  # (the package's controllers: the test below, in fewer calls)
    if (
        isinstance(reply, tuple)
        and len(reply) == 2
        # (a dict or a row: no ABC check)
        and (type(reply[1]) in (dict, SignalRow) or isinstance(reply[1], Mapping))
    ):
        return Reply(reply[0], reply[1])
    return Reply(reply, _NO_SIGNALS)


def recorded_name(name: str) -> str:
    """The ``trajectory.npz`` key of a controller signal: standard names stay, others get
    the ``ctrl_`` prefix."""
    return name if name in STANDARD_SIGNALS else USER_SIGNAL_PREFIX + name
