"""What a run needs, as frozen dataclasses (the TOML form is in :mod:`ffsm_pin.scenario.file`).

A :class:`Scenario` describes a run: a robot, an initial condition, a reference, the
controller that runs (its type, its own parameters, the initial estimates it is handed), the
run's performance specification (:class:`Performance`: the funnels and the singularity
threshold every controller is judged by) and the simulation horizon. The paper's cases are
scenario files shipped in ``ffsm_pin/scenario/builtin/``.

The dataclasses hold the defaults; the rules a value must follow (choices, ranges, sizes for
the robot and the task) are checked once, by the scenario file's schema
(:mod:`ffsm_pin.scenario.schema`): on loading a file, and for a scenario built in Python by
:func:`~ffsm_pin.scenario.file.check_scenario`, which :func:`~ffsm_pin.sim.setup.prepare`
calls first. Construction only refuses what would make the object itself inconsistent (a
reference given twice, an initial velocity given two ways or not at all).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._docstrings import fill_doc
from ..attitude import mrp
from ..control.funnel import FunnelParams
from ..control.gains import SingularityPolicy
from ..control.lu_jia_params import LuJiaParams
from ..errors import ParameterError
from ._docs import SCENARIO_DOC
from .devices import ActuatorSpec, SensorSpec
from .target_spec import TargetSpec
from .trajectory import PiecewisePolynomial, ReferenceData

ESTIMATE_KINDS = ("paper", "true", "perturbed", "explicit")
#: The plant's integrators a scenario may name (``[sim] integrator``; :mod:`ffsm_pin.sim.plant`).
INTEGRATORS = ("semi-implicit", "rk4")


@dataclass(frozen=True)
class Harmonic:
    """One term ``amplitude * cos(frequency t)`` or ``amplitude * sin(frequency t)``.

    Attributes
    ----------
    amplitude : float
        Amplitude [units of the component].
    frequency : float
        Angular frequency [rad/s].
    """

    amplitude: float
    frequency: float  # [rad/s]


@dataclass(frozen=True)
class ComponentReference:
    """``value(t) = c + sum a_i cos(w_i t) + sum b_j sin(w_j t)`` for one task component.

    Attributes
    ----------
    c : float
        The constant term.
    cos, sin : tuple of Harmonic
        The cosine terms (a_i, w_i) and the sine terms (b_j, w_j).
    """

    c: float = 0.0
    cos: tuple[Harmonic, ...] = ()
    sin: tuple[Harmonic, ...] = ()

    @fill_doc(SCENARIO_DOC)
    def derivative(self, t, order: int = 0):
        """d^order value / dt^order at t (t may be complex, for complex-step derivatives).

        Parameters
        ----------
        %(t_order)s
        """
        out = self.c if order == 0 else 0.0
        for h in self.cos:  # d^k/dt^k cos(wt) = w^k cos(wt + k pi/2)
            out = out + h.amplitude * h.frequency**order * np.cos(
                h.frequency * t + order * np.pi / 2
            )
        for h in self.sin:
            out = out + h.amplitude * h.frequency**order * np.sin(
                h.frequency * t + order * np.pi / 2
            )
        return out


ORIGINS = ("absolute", "initial")  # [reference] origin


def _after(initial: np.ndarray, relative: np.ndarray) -> np.ndarray:
    """An attitude ``relative`` to ``initial``: planar angles add; MRPs compose (|s| <= 1)."""
    if initial.size == 1:
        return initial + relative
    return mrp.from_rotation(mrp.to_rotation(initial) @ mrp.to_rotation(relative))


@dataclass(frozen=True)
class Reference:
    """Desired end-effector task z_e,d(t) (Eq. 80 form) and base attitude q_b,d.

    Attributes
    ----------
    ee : tuple of ComponentReference
        ``task = "pose"``: one entry per pose component (planar x, y, attitude [rad];
        spatial x, y, z [m] then an MRP s1, s2, s3); ``"position"``: the position components
        only.
    base_attitude : tuple of float
        Planar (angle,) [rad], spatial an MRP (3).
    task : str
        ``"pose"`` or ``"position"``.
    origin : str
        ``"absolute"``, or ``"initial"``: the constant terms ``c`` of ``ee`` and
        ``base_attitude`` are relative to the initial pose, resolved by :meth:`resolved`.
    data : ReferenceData or None
        A reference from data instead of harmonics (``ee`` is then empty): samples through a
        C2 cubic spline or rest-to-rest waypoints
        (:class:`~ffsm_pin.scenario.trajectory.ReferenceData`); with ``origin = "initial"``
        every sample is relative to the initial pose.
    """

    ee: tuple[ComponentReference, ...]
    base_attitude: tuple[float, ...] = (0.0,)
    task: str = "pose"
    origin: str = "absolute"
    data: ReferenceData | None = None
    if TYPE_CHECKING:  # set in __post_init__ (the kernels' arrays): not fields at run time
        _c: np.ndarray = field(init=False)
        _A: np.ndarray = field(init=False)
        _amp: np.ndarray = field(init=False)
        _freq: np.ndarray = field(init=False)
        _phase: np.ndarray = field(init=False)
        _pp: PiecewisePolynomial = field(init=False)

    def __post_init__(self) -> None:
        if self.data is not None and self.ee:
            raise ParameterError(
                "reference: give the end-effector reference once: harmonics (ee) or data "
                "(ee_file, ee_samples or ee_waypoints), not both"
            )
        # all harmonic terms flattened: value = c + A @ (amp * cos(freq t + phase))
        terms = [
            (i, h.amplitude, h.frequency, phase)
            for i, comp in enumerate(self.ee)
            for hs, phase in ((comp.cos, 0.0), (comp.sin, -np.pi / 2))
            for h in hs
        ]
        idx = np.array([x[0] for x in terms], dtype=int)
        A = np.zeros((len(self.ee), len(terms)))
        A[idx, np.arange(len(terms))] = 1.0
        object.__setattr__(self, "_c", np.array([comp.c for comp in self.ee], dtype=float))
        object.__setattr__(self, "_A", A)
        object.__setattr__(self, "_amp", np.array([x[1] for x in terms], dtype=float))
        object.__setattr__(self, "_freq", np.array([x[2] for x in terms], dtype=float))
        object.__setattr__(self, "_phase", np.array([x[3] for x in terms], dtype=float))
        n = self.n_components
        if self.data is not None:
            object.__setattr__(self, "_c", np.zeros(n))
            object.__setattr__(self, "_A", np.zeros((n, 0)))
        pp = self.data.polynomial() if self.data is not None else PiecewisePolynomial.empty(n)
        object.__setattr__(self, "_pp", pp)

    @property
    def n_components(self) -> int:
        """Task components of z_e,d (one per entry of ``ee``, or per data column)."""
        return self.data.n_components if self.data is not None else len(self.ee)

    def kernel_arrays(self) -> tuple[np.ndarray, ...]:
        """The arrays the compiled periods evaluate z_e,d with: constant terms, harmonic
        selection, amplitudes, frequencies [rad/s], phases [rad], and the piecewise
        polynomial of a reference from data (no segments for harmonics); C-contiguous float
        arrays (the stored ones themselves, not copies)."""
        arrays = (self._c, self._A, self._amp, self._freq, self._phase, self._pp.table)
        return tuple(np.ascontiguousarray(x, dtype=float) for x in arrays)

    def resolved(self, z_e0, q_b0, m2: int) -> Reference:
        """The absolute reference of an ``origin = "initial"`` one, for the initial
        end-effector pose ``z_e0`` and base attitude ``q_b0`` (``self`` when absolute).

        Positions and planar angles: c + z_e(0), q_b,d + q_b(0). Spatial attitudes (MRPs):
        the given rotation after the initial one, R(c) -> R(q_e(0)) R(c) and
        R(q_b,d) -> R(q_b(0)) R(q_b,d) (docs/cli.md, ``[reference]``). Only the constant terms
        move; the harmonic terms are unchanged.

        Parameters
        ----------
        z_e0 : array_like
            The initial end-effector pose.
        q_b0 : float or array_like
            The initial base attitude [rad] or MRP.
        m2 : int
            Position components.

        Returns
        -------
        Reference
            The absolute reference.
        """
        if self.origin == "absolute":
            return self
        z0 = np.atleast_1d(np.asarray(z_e0, dtype=float))
        n_att = len(self.base_attitude)
        base = _after(np.atleast_1d(np.asarray(q_b0, dtype=float)), np.array(self.base_attitude))
        base_attitude = tuple(float(x) for x in base)
        if self.data is not None:  # every sample relative to the initial pose
            z = np.array(self.data.values, dtype=float)
            z[:, :m2] += z0[:m2]
            if z.shape[1] > m2:
                z[:, m2:] = [_after(z0[m2 : m2 + n_att], row) for row in z[:, m2:]]
            return dataclasses.replace(
                self,
                data=self.data.with_values(z),
                base_attitude=base_attitude,
                origin="absolute",
            )
        c = np.array([comp.c for comp in self.ee], dtype=float)
        new_c = c.copy()
        new_c[:m2] = c[:m2] + z0[:m2]
        if len(c) > m2:  # the task has the end-effector attitude
            new_c[m2:] = _after(z0[m2 : m2 + n_att], c[m2:])
        ee = tuple(
            dataclasses.replace(comp, c=float(v)) for comp, v in zip(self.ee, new_c, strict=True)
        )
        return dataclasses.replace(self, ee=ee, base_attitude=base_attitude, origin="absolute")

    def ee_pose(self, t):
        """z_e,d(t) [m, m, rad] (t may be complex)."""
        out = self._c + self._A @ (self._amp * np.cos(self._freq * t + self._phase))
        return out if self.data is None else out + self._pp.derivative(t, 0)

    def ee_rate(self, t):
        """dz_e,d/dt [m/s, m/s, rad/s] (t may be complex)."""
        out = self._A @ (-self._amp * self._freq * np.sin(self._freq * t + self._phase))
        return out if self.data is None else out + self._pp.derivative(t, 1)

    def ee_accel(self, t):
        """d^2 z_e,d/dt^2 [m/s^2, m/s^2, rad/s^2] (t may be complex)."""
        out = self._A @ (-self._amp * self._freq**2 * np.cos(self._freq * t + self._phase))
        return out if self.data is None else out + self._pp.derivative(t, 2)

    def sample(self, ts) -> tuple[np.ndarray, np.ndarray]:
        """(z_e,d, dz_e,d/dt) at the times ``ts`` [s], each of shape (len(ts), n_components)."""
        arg = np.multiply.outer(np.asarray(ts, dtype=float), self._freq) + self._phase
        pose = self._c + (self._amp * np.cos(arg)) @ self._A.T
        rate = (-self._amp * self._freq * np.sin(arg)) @ self._A.T
        if self.data is not None:
            pose = pose + self._pp.sample(ts, 0)
            rate = rate + self._pp.sample(ts, 1)
        return pose, rate


@dataclass(frozen=True)
class RobotSpec:
    """Which robot: ``base = "planar"`` or ``"free-flyer"`` (spatial; then also
    ``locked_joints``, ``satellite`` and ``wheels``); ``payload`` (either base).

    Attributes
    ----------
    urdf : str
        Shipped name or path (relative to relative_to).
    base : str
        ``"planar"`` or ``"free-flyer"``.
    end_effector : str
        Name of the end-effector frame.
    relative_to : str or None
        Folder of the scenario file.
    locked_joints : tuple of (str, float)
        ((name, value), ...) [rad or m], free-flyer only.
    satellite, payload, wheels : Satellite, Payload, Wheels or None
        A bus added under an arm-only URDF's root, a body in the hand, wheels on the bus.
    """

    urdf: str = "ffsm_planar4.urdf"  # shipped name or path (relative to relative_to)
    base: str = "planar"
    end_effector: str = "ee"
    relative_to: str | None = None  # folder of the scenario file
    locked_joints: tuple[tuple[str, float], ...] = ()
    satellite: Any = None  # ffsm_pin.robot.Satellite | None
    payload: Any = None  # ffsm_pin.robot.Payload | None, held by the end effector
    wheels: Any = None  # ffsm_pin.robot.wheels.Wheels | None, on the bus


@dataclass(frozen=True)
class InitialCondition:
    """Initial plant state (planar / spatial sizes).

    Base velocity, exactly one of (all in the inertial frame):

    * base_twist = (v_x, v_y, w_b) / (v (3), w_b (3)) [m/s, rad/s];
    * com_velocity = v_0 (2 / 3) [m/s] with base_rate = w_b (number / 3) [rad/s];
    * com_velocity with angular_momentum = A_0 about the system CoM (number / 3) [kg m^2/s].

    Attributes
    ----------
    base_pose : tuple of float
        (x, y, q_b) [m, m, rad] / (x, y, z, s1, s2, s3) [m, MRP], base frame origin in the
        inertial frame.
    joints, joint_rates : tuple of float
        q_m(0) [rad], w_m(0) [rad/s].
    com_at_origin : bool
        Shift the position so that the *system* CoM starts at the inertial origin.
    base_twist : tuple of float or None
        (v_x, v_y, w_b) / (v (3), w_b (3)) [m/s, rad/s].
    com_velocity : tuple of float or None
        v_0 (2 / 3) [m/s].
    base_rate : float or tuple of float or None
        w_b (number / 3) [rad/s].
    angular_momentum : float or tuple of float or None
        A_0 about the system CoM (number / 3) [kg m^2/s].
    attitude_error : float or tuple of float or None
        An initial base attitude error applied on top of base_pose's attitude: planar an
        angle added to q_b [rad]; spatial a rotation vector (axis times angle) [rad] about
        inertial axes, R(0) = exp([e]x) R(base_pose). A campaign draws it in a random
        direction with a given angle (docs/campaigns.md, ``{ angle = ... }``).
    """

    base_pose: tuple[float, ...]
    joints: tuple[float, ...]
    joint_rates: tuple[float, ...]
    com_at_origin: bool = False
    base_twist: tuple[float, ...] | None = None
    com_velocity: tuple[float, ...] | None = None
    base_rate: float | tuple[float, ...] | None = None
    angular_momentum: float | tuple[float, ...] | None = None
    attitude_error: float | tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        by_twist = self.base_twist is not None
        by_com = self.com_velocity is not None
        n_rate = (self.base_rate is not None) + (self.angular_momentum is not None)
        if by_twist and (by_com or n_rate):
            raise ParameterError(
                "initial velocity: give either base_twist, or com_velocity with one of "
                "base_rate / angular_momentum, not both"
            )
        if by_com and n_rate != 1:
            raise ParameterError(
                "initial velocity: com_velocity needs exactly one of base_rate or angular_momentum"
            )
        if not by_twist and not by_com:
            raise ParameterError(
                "initial velocity: give base_twist = [v_x, v_y, w_b], or com_velocity = "
                "[v_x, v_y] with base_rate or angular_momentum"
            )


@dataclass(frozen=True)
class Estimates:
    """Initial parameter estimates: 'paper' (Table 2), 'true', 'perturbed' or 'explicit'.

    'perturbed': every body's mass, centre of mass and rotational inertia drawn as a rigid body
    within ``spread`` of the truth, from a generator seeded with ``seed``, the barycentric
    estimates derived from the drawn bodies (:func:`ffsm_pin.sim.estimates.perturb_body`,
    docs/model.md section 6).

    Attributes
    ----------
    initial : str
        'paper', 'true', 'perturbed' or 'explicit'.
    spread : float
        Relative spread of 'perturbed'.
    seed : int
        Seed of 'perturbed'.
    theta_z, theta_d, theta_b : tuple of float or None
        The 'explicit' vectors.
    """

    initial: str = "paper"
    spread: float = 0.3
    seed: int = 0
    theta_z: tuple[float, ...] | None = None
    theta_d: tuple[float, ...] | None = None
    theta_b: tuple[float, ...] | None = None


def _paper_funnel_b() -> FunnelParams:
    return FunnelParams((0.4,), (0.03,), (0.22,), (0.8,))


def _paper_funnel_z() -> FunnelParams:
    return FunnelParams((1.0, 1.0, 0.2), (0.08, 0.08, 0.05), (0.22,) * 3, (0.8,) * 3)


@dataclass(frozen=True)
class Performance:
    """The run's performance specification: what every run is judged by, whatever its
    controller (docs/controllers.md). In the file: ``[controller.funnel]`` and
    ``[controller.singularity] threshold``.

    Attributes
    ----------
    funnel_b, funnel_z : FunnelParams
        The base attitude and end-effector task funnels (Eqs. 16, 17): ``funnel_ok_b``,
        ``funnel_ok_z``, ``rho_b``, ``rho_z``, the bounds and the settle times judge the true
        errors by them. Defaults: the paper's planar pose funnels. A controller that uses
        funnels itself (``needs_funnels``, the lu-jia controller's transformation) uses these.
    singularity_threshold : float
        The singularity measure's threshold [m]: sigma_min of the inverted task Jacobian below
        it is near singular (``damping_threshold`` in summary.json, ``--check``); the
        built-in controllers damp their pseudo-inverse below it.
    """

    funnel_b: FunnelParams = field(default_factory=_paper_funnel_b)
    funnel_z: FunnelParams = field(default_factory=_paper_funnel_z)
    singularity_threshold: float = SingularityPolicy.threshold


@dataclass(frozen=True)
class ControllerSpec:
    """``[controller]``: which controller runs (``type``), its free ``params`` table, the
    initial ``estimates`` it is handed (``ctx.estimates``), and the lu-jia controller's own
    parameters, ``lu_jia`` (the paper's keys at the ``[controller]`` level of the file; other
    controllers may read them where they use them, docs/controllers.md). What the run is judged
    by is not here: :attr:`Scenario.performance`.

    Attributes
    ----------
    type : str
        A built-in, installed or user controller (:mod:`ffsm_pin.control.registry`).
    params : mapping
        The ``[controller.params]`` table.
    estimates : Estimates
        The initial estimates (``[controller.estimates]``).
    lu_jia : LuJiaParams
        The lu-jia controller's own parameters: scheme, gains, null space.
    """

    type: str = "lu-jia"  # a built-in, installed or user controller (control.registry)
    params: Mapping[str, Any] = field(default_factory=dict)  # [controller.params]
    estimates: Estimates = field(default_factory=Estimates)
    lu_jia: LuJiaParams = field(default_factory=LuJiaParams)  # scheme, gains, null space

    @property
    def scheme(self) -> str:
        """The lu-jia controller's scheme (``lu_jia.scheme``); ``"known-model"`` also makes the
        run's initial estimates the truth, for any controller (sim/estimates.py)."""
        return self.lu_jia.scheme


@dataclass(frozen=True)
class Scenario:
    """Everything one run needs.

    Attributes
    ----------
    robot : RobotSpec
        Which robot.
    initial : InitialCondition
        The initial plant state.
    reference : Reference
        The task and base attitude references.
    controller : ControllerSpec
        Which controller, its parameters and estimates.
    duration, dt : float
        The run's horizon and the control period [s].
    name : str
        The scenario's name.
    source : Path or None
        The file it was read from, if any.
    description : str
        Free text.
    integrator : str
        Plant integrator, one of ``plant.INTEGRATORS``.
    substeps : int
        Plant steps per control step dt, joint torque held over dt.
    actuators : ActuatorSpec
        Between the controller and the plant; ideal by default.
    sensors : SensorSpec
        Between the plant and the controller; exact by default.
    performance : Performance
        What the run is judged by.
    target : TargetSpec or None
        ``[target]``, a body tumbling beside a free-flyer robot (docs/capture.md).
    """

    robot: RobotSpec
    initial: InitialCondition
    reference: Reference
    controller: ControllerSpec
    duration: float = 30.0  # [s]
    dt: float = 1e-3  # [s]
    name: str = "scenario"
    source: Path | None = None  # the file it was read from, if any
    description: str = ""
    integrator: str = "semi-implicit"  # plant integrator, one of plant.INTEGRATORS
    substeps: int = 1  # plant steps per control step dt, joint torque held over dt
    actuators: ActuatorSpec = field(default_factory=ActuatorSpec)  # ideal by default
    sensors: SensorSpec = field(default_factory=SensorSpec)  # exact by default
    performance: Performance = field(default_factory=Performance)  # what the run is judged by
    target: TargetSpec | None = None  # [target], free-flyer robots only
