"""Reaction wheels in the loop (issue 40, ``[robot.satellite.wheels]``; docs/capture.md,
"Wheels in the loop").

:func:`loop_plant` is the loop's plant: the plain :class:`~.plant.Plant` without wheels, a
:class:`WheelsInLoop` with them. :class:`WheelsInLoop` has the plant's interface the loop and
the capture hook use (``advance``, ``acceleration``, ``reset``, ``project``, ``state_status``,
``momentum_rows``, ``with_robot``; the rest is the inner plant's) and steps the robot with its
wheels (:class:`~.wheels.WheeledPlant`: total momentum kept, limits applied). Two more methods
are the loop's hooks: :meth:`WheelsInLoop.command`, after the controller's step, reads the wheel
torques (the controller's optional ``wheel_torque(meas)``; else the wheels' own ``control``:
zero or ``"attitude-pd"``), and :meth:`WheelsInLoop.write` records the wheels' row.
:meth:`WheelsInLoop.total_momentum_rows` adds R_b A h to the recorded momentum, so that
``P``, ``L`` and ``drift_P``, ``drift_L`` are the whole system's; :class:`WheelsOutcome` is the
summary's ``wheel_saturation_fraction``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import cast

import numpy as np
import pinocchio as pin

from .._docstrings import fill_doc
from ..attitude.mrp import to_rotation
from ..robot.wheels import Wheels
from ._docs import SIM_DOC
from .plant import Plant
from .setup import Setup
from .wheels import WheeledPlant

#: The per-step columns of a run with wheels (each (N,), one per wheel): h [N m s], the
#: spin relative to the bus [rad/s], the motor torque applied and the torque commanded [N m].
WHEEL_COLUMNS = ("wheel_momentum", "wheel_speed", "wheel_torque", "wheel_torque_cmd")

MomentumRows = Callable[[Mapping[str, np.ndarray]], tuple[np.ndarray, np.ndarray]]


@fill_doc(SIM_DOC)
def wheel_shapes(setup: Setup) -> dict[str, tuple[int, ...]]:
    """The recorded shapes of the wheels' columns (none without wheels).

    %(params_setup)s

    Returns
    -------
    dict of str to tuple
        :data:`WHEEL_COLUMNS` -> (N,), or empty.
    """
    wheels = setup.scenario.robot.wheels
    return {} if wheels is None else {key: (wheels.n,) for key in WHEEL_COLUMNS}


@dataclass(frozen=True)
class WheelsOutcome:
    """What the summary says of the wheels.

    Attributes
    ----------
    saturation_fraction : float
        Fraction of control periods in which some wheel's torque was cut by its torque or
        momentum limit (in the period's last plant step).
    wheels : Wheels or None
        The wheels (their axes, for the replay's arrow of the stored momentum).
    """

    saturation_fraction: float
    wheels: Wheels | None = None

    def summary(self) -> dict:
        """The summary.json keys.

        Returns
        -------
        dict
            ``wheel_saturation_fraction``.
        """
        return {"wheel_saturation_fraction": self.saturation_fraction}


@fill_doc(SIM_DOC)
class WheelsInLoop:
    """The loop's plant with reaction wheels on the bus (see the module docstring).

    Parameters
    ----------
    robot : Robot
        The plant's robot (free-flyer root).
    wheels : Wheels
        The wheels.
    integrator : str
        The plant's integrator.
    base_attitude : array_like, shape (3,)
        The desired bus attitude (MRP) of ``control = "attitude-pd"``.
    dt_step : float
        The plant's step [s] (the last period's torque limits).
    project_position : bool
        Keep the CoM on its straight line (:class:`~.plant.Plant`'s position projection).
    """

    def __init__(
        self,
        robot,
        wheels: Wheels,
        integrator: str,
        base_attitude,
        dt_step: float,
        project_position: bool = False,
    ) -> None:
        self.wheeled = WheeledPlant(
            robot, wheels, integrator=integrator, project_position=project_position
        )
        self.dt_step = dt_step
        self.wheels = wheels
        self.h = np.zeros(wheels.n)  # wheel momenta now [N m s]
        self.tau_cmd = np.zeros(wheels.n)  # the period's command [N m]
        self._row = (self.h, np.zeros(wheels.n))  # (h, torque applied) of the period
        self.saturated = 0  # control periods with a wheel cut by a limit
        self._R_d = to_rotation(np.asarray(base_attitude, dtype=float))
        self.holding = False  # a [capture]'s hand holds the target (set by with_robot)

    def __getattr__(self, name: str):  # the inner plant's (model, data, robot, n_linear, ...)
        if name.startswith("__") or name == "wheeled":  # (copy.copy, before __dict__ is)
            raise AttributeError(name)
        return getattr(self.wheeled.plant, name)

    @property
    def project_momentum(self) -> bool:
        """The total momentum is restored after each plant step."""
        return self.wheeled.project_momentum

    def with_robot(self, robot) -> WheelsInLoop:
        """Step another robot (the merged one at capture) with the same wheels, their state
        and command; the loop's hooks stay this object.

        Parameters
        ----------
        robot : Robot
            The new robot.

        Returns
        -------
        WheelsInLoop
            ``self``; :meth:`reset` sets the total momentum to keep.
        """
        inner = self.wheeled.plant
        self.wheeled = WheeledPlant(
            robot,
            self.wheels,
            integrator=inner.integrator,
            project_position=inner.project_position,
        )
        self.holding = True  # (only a capture swaps the robot)
        return self

    def reset(self, q, v) -> None:
        """Keep the total momentum of (q, v) and the wheels' h from now on.

        Parameters
        ----------
        q, v : ndarray
            The robot's state (Pinocchio convention).
        """
        self.wheeled.reset(q, v, self.h)

    def project(self, q, v) -> np.ndarray:
        """The base twist that restores the total momentum at q (a new array).

        Parameters
        ----------
        q, v : ndarray
            The robot's state (Pinocchio convention).

        Returns
        -------
        ndarray, shape (nv,)
            v with the base twist corrected.
        """
        wheeled = self.wheeled
        return wheeled.plant.project(q, v, wheeled.total0 - wheeled.stored(q, self.h))

    def command(self, controller, meas) -> None:
        """The loop's hook after the controller's step: the period's wheel torques.

        Parameters
        ----------
        controller : object
            The run's controller; its optional ``wheel_torque(meas)`` gives them [N m].
        meas : Measurement
            What the controller saw this period.
        """
        hook = getattr(controller, "wheel_torque", None)
        if hook is not None:
            tau = np.asarray(hook(meas), dtype=float)
            if tau.shape != (self.wheels.n,) or not np.isfinite(tau).all():
                raise ValueError(
                    f"wheel_torque returned {tau.tolist()!r:.80} (shape {tau.shape}); expected "
                    f"({self.wheels.n},) finite numbers, one per wheel [N m]"
                )
        elif self.wheels.control == "attitude-pd" or (
            self.holding and self.wheels.control == "attitude-pd-after-capture"
        ):
            R = to_rotation(np.asarray(meas.q_b, dtype=float))
            phi = pin.log3(self._R_d.T @ R)  # its axis: the same in both frames
            tau = self.wheels.attitude_pd(phi, R.T @ meas.w[:3])
        else:
            tau = np.zeros(self.wheels.n)
        self.tau_cmd = tau

    def advance(self, q, v, u_m, dt: float, substeps: int = 1):
        """One control period (:meth:`WheeledPlant.advance` with the period's command).

        Parameters
        ----------
        q, v : ndarray
            The robot's state at the start.
        %(u_m_held)s
        %(dt_substeps)s

        Returns
        -------
        tuple of ndarray
            (q, v, a): the state after dt and the acceleration at the start.
        """
        step = self.wheeled.advance(q, v, self.h, u_m, self.tau_cmd, dt, substeps)
        self._row = (self.h, step.tau_w)
        self.saturated += bool((step.tau_w != self.tau_cmd).any())
        self.h = step.h
        return step.q, step.v, step.a

    def acceleration(self, q, v, u_m) -> np.ndarray:
        """The acceleration at the last period, the wheels' torque on the bus included.

        Parameters
        ----------
        q, v : ndarray
            The robot's state.
        u_m : ndarray, shape (n,)
            Joint torques [N m].

        Returns
        -------
        ndarray, shape (nv,)
            The acceleration (Pinocchio convention).
        """
        wheeled = self.wheeled
        tau = self.wheels.limit(self.h, self.tau_cmd, self.dt_step)
        self._row = (self.h, tau)
        self.saturated += bool((tau != self.tau_cmd).any())  # (the last period counts too)
        torque = self.wheels.bus_torque(self.h, tau, wheeled.bus_rate(v))
        return wheeled.plant.acceleration(q, v, u_m, base_wrench=np.r_[np.zeros(3), torque])

    def write(self, columns: Mapping[str, np.ndarray], i: int, v) -> None:
        """Record the period's row ``i``: h and the spin rates at its start, the torque applied
        and the torque commanded.

        Parameters
        ----------
        columns : mapping of str to ndarray
            The recorder's columns.
        i : int
            The row.
        v : ndarray
            The robot's velocity at the period's start.
        """
        h, tau = self._row
        columns["wheel_momentum"][i] = h
        columns["wheel_speed"][i] = self.wheels.spin_rates(h, self.wheeled.bus_rate(v))
        columns["wheel_torque"][i] = tau
        columns["wheel_torque_cmd"][i] = self.tau_cmd

    def total_momentum_rows(self, robot_rows: MomentumRows | None) -> MomentumRows:
        """The recorded (P, L) of robot (and target) plus wheels: L + R_b A h per row.

        Parameters
        ----------
        robot_rows : callable or None
            block -> (P, L) without the wheels; None: the plant's own
            (:meth:`~.plant.Plant.momentum_rows`).

        Returns
        -------
        callable
            block (``q``, ``v``, ``wheel_momentum`` and what ``robot_rows`` reads) -> (P, L).
        """
        wheeled = self.wheeled

        def rows(block: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
            if robot_rows is None:
                P, L = wheeled.plant.momentum_rows(block["q"], block["v"])
            else:
                P, L = robot_rows(block)
            rows_h = zip(block["q"], block["wheel_momentum"], strict=True)
            stored = [wheeled.stored(q, h)[3:] for q, h in rows_h]
            return P, L + np.reshape(stored, np.shape(L))

        return rows

    def outcome(self, periods: int) -> WheelsOutcome:
        """The summary's wheel keys after ``periods`` control periods.

        Parameters
        ----------
        periods : int
            Control periods run.

        Returns
        -------
        WheelsOutcome
            The saturation fraction.
        """
        return WheelsOutcome(self.saturated / max(1, periods), self.wheels)

    def recorded_outcome(self, blocks: Callable) -> WheelsOutcome:
        """The summary's wheel keys from recorded rows (a recovered run): the fraction of rows
        whose applied torque differs from the command, :meth:`outcome`'s count when every
        period was recorded (a sample of the periods otherwise).

        Parameters
        ----------
        blocks : callable
            keys -> iterator of row blocks (``Signals.blocks``) with ``wheel_torque`` and
            ``wheel_torque_cmd``.

        Returns
        -------
        WheelsOutcome
            The saturation fraction (NaN without rows).
        """
        cut = rows = 0
        for b in blocks(["wheel_torque", "wheel_torque_cmd"]):
            cut += int(np.count_nonzero((b["wheel_torque"] != b["wheel_torque_cmd"]).any(axis=1)))
            rows += len(b["wheel_torque"])
        return WheelsOutcome(cut / rows if rows else float("nan"), self.wheels)


@fill_doc(SIM_DOC)
def loop_plant(setup: Setup) -> tuple[Plant, WheelsInLoop | None]:
    """The loop's plant: a :class:`~.plant.Plant`, or with ``[robot.satellite.wheels]`` a
    :class:`WheelsInLoop` (returned twice: it is also the loop's wheel hook).

    %(params_setup)s

    Returns
    -------
    plant : Plant
        What the loop steps (a :class:`WheelsInLoop` has the plant's interface).
    wheels : WheelsInLoop or None
        The wheels' hooks, None without wheels.
    """
    sc = setup.scenario
    # with a [target], the robot's CoM kept on its line: the whole system's angular momentum
    # depends on where it is (docs/capture.md, "Momentum"); without, the runs of before
    position = setup.target is not None
    if sc.robot.wheels is None:
        return Plant(setup.robot, integrator=sc.integrator, project_position=position), None
    plant = WheelsInLoop(
        setup.robot, sc.robot.wheels, sc.integrator, sc.reference.base_attitude,
        sc.dt / sc.substeps, position,
    )  # fmt: skip
    return cast(Plant, plant), plant  # (duck-typed: the interface the loop uses)
