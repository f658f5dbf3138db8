"""The plant: Pinocchio's ABA integrated on the configuration Lie group, with momentum projection.

Planar roots (``JointModelPlanar``: 3 conserved quantities P_x, P_y, L_z) and free-flyer roots
(``JointModelFreeFlyer``: 6 conserved quantities, the linear momentum P and the angular momentum
L about the system CoM) are handled alike; the root is read from ``model.joints[1]``.

One step (docs/model.md section 4), with ``tau = (0, u_m)`` (free-floating: no base actuation,
zero gravity):

* ``"semi-implicit"`` (default): ``a = ABA(q, v, tau)``, ``v+ = v + dt a``,
  ``q+ = integrate(q, dt v+)`` (semi-implicit / symplectic Euler on the configuration Lie group,
  never ``q + v dt``). First order in dt.
* ``"rk4"``: classical RK4 in the Runge-Kutta-Munthe-Kaas form (:mod:`.integrators`), fourth
  order in dt for the base pose too.

After either step, the projection: the base twist is recomputed from the conserved centroidal
momentum at the new configuration, ``A_g,base(q+) v_base = h_0 - A_g,joints(q+) w_m``, so the
conserved quantities stay exact to rounding for any dt. Plain semi-implicit Euler drifts in
momentum by O(dt); the projection removes that drift without changing the order of accuracy of
the trajectory (it moves the state by as much as the integrator's own local error).

Optionally (``project_position=True``; a run with a ``[target]`` turns it on), the position
projection, its counterpart for the CoM: with no external force the robot's CoM moves on the
straight line ``c(t) = c(0) + P t / m``, which no finite-order integrator keeps (semi-implicit
Euler leaves a first-order error, ~5e-8 m after 1 s at dt = 2 ms). After each step the root's
translation (the first ``n_linear`` entries of q, in the root joint's parent frame) is moved so
that the CoM is back on its line: a translation of the whole system, which changes no velocity
and no momentum about the CoM, so it is exact to rounding (docs/capture.md, "Momentum").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin
from numba import njit

from .._array_kernels import put, solve
from .._docstrings import doc_entries, fill_doc
from ..control import _first_compile
from ..errors import ParameterError, choices_text
from ..scenario.spec import INTEGRATORS
from .integrators import chart_block, gauss_solve, rkmk4_step

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    q_v="""
        q, v : ndarray
            State (Pinocchio convention).""",
    q_v_start="""
        q, v : ndarray
            State at the start (Pinocchio convention).""",
    u_m="""
        u_m : ndarray, shape (n,)
            Joint torques [N m], held.""",
    returns_stepresult="""
        Returns
        -------
        StepResult
            (q, v) after dt and the acceleration at the start.""",
    params_q_v_start_u_m=("q_v_start", "u_m"),
)

# root joint -> (base velocity size, rows of the centroidal momentum h_g = (P, L) kept,
# linear entries of the base velocity (= entries of P; = the root's translation entries of q,
# the position projection's)
_ROOTS = {
    "JointModelPlanar": (3, np.array([0, 1, 5]), 2),  # P_x, P_y, L_z
    "JointModelFreeFlyer": (6, np.arange(6), 3),  # P (inertial frame), L about the CoM
}


@njit(cache=True)
def _project_base(Ag: np.ndarray, v: np.ndarray, h0: np.ndarray, rows: np.ndarray) -> None:
    """Replace, in place, the base twist of v (its first ``rows.size`` entries) by the solution
    of ``A_g,base v_base = h0 - A_g,joints v_joints`` on the given rows of A_g.

    Compiled: it is a few lines of linear algebra on a 3 x 3 or 6 x 6 system, which numpy's
    wrappers make cost more than the rest of the plant step. The planar 3 x 3 system goes to
    LAPACK (as it always did, so planar runs stay bit for bit what they were); the free-flyer
    6 x 6 one to :func:`~.integrators.gauss_solve`, several times cheaper than LAPACK's
    wrapper at this size.
    """
    nb = rows.size
    A = np.empty((nb, nb))
    rhs = h0.copy()
    for r in range(nb):
        row = rows[r]
        for j in range(nb):
            A[r, j] = Ag[row, j]
        for j in range(nb, v.size):
            rhs[r] -= Ag[row, j] * v[j]
    if nb == 3:
        put(v, 0, solve(A, rhs))  # LAPACK's dgesv, as np.linalg.solve (_array_kernels.solve)
    else:
        gauss_solve(A, rhs, v)


@njit(cache=True)
def _euler_velocity(v: np.ndarray, a: np.ndarray, dt: float, out: np.ndarray) -> None:
    """out = (v + dt a, dt (v + dt a), a): the semi-implicit velocity update, the configuration
    increment and a copy of a, in one compiled call instead of four numpy operations."""
    for i in range(v.size):
        v_new = v[i] + dt * a[i]
        out[0, i] = v_new
        out[1, i] = dt * v_new
        out[2, i] = a[i]


#: :meth:`Plant.state_status` codes
STATE_OK, STATE_NONFINITE, STATE_BLOW_UP = range(3)


@njit(cache=True)
def _state_status(q: np.ndarray, v: np.ndarray, n_linear: int, rate_limit: float) -> int:
    """STATE_NONFINITE if q or v holds a non-finite entry, else STATE_BLOW_UP if some rate
    ``|v[i]|``, ``i >= n_linear``, exceeds ``rate_limit``, else STATE_OK: one compiled pass
    instead of three numpy reductions a step."""
    for x in q:
        if not np.isfinite(x):
            return STATE_NONFINITE
    for x in v:
        if not np.isfinite(x):
            return STATE_NONFINITE
    for i in range(n_linear, v.size):
        if abs(v[i]) > rate_limit:
            return STATE_BLOW_UP
    return STATE_OK


class StepResult(NamedTuple):
    """State after one step and the acceleration used for it."""

    q: np.ndarray  # configuration after the step (Pinocchio convention)
    v: np.ndarray  # velocity after the step (Pinocchio convention, base twist in base frame)
    a: np.ndarray  # ABA acceleration at the start of the step [nv]


def root_kind(model: pin.Model) -> str:
    """Pinocchio's short name of the root joint: ``"JointModelPlanar"`` or
    ``"JointModelFreeFlyer"``; anything else is a :class:`ParameterError`."""
    name = model.joints[1].shortname() if model.njoints > 1 else "none"
    if name not in _ROOTS:
        raise ParameterError(
            f"plant: root joint {name!r} is not free-floating; valid choices: "
            f"{choices_text(_ROOTS)}"
        )
    return name


@fill_doc(_DOC)
class Plant:
    """Momentum-exact integrator of a free-floating robot (planar or free-flyer root).

    Parameters
    ----------
    robot : Robot or pin.Model
        The loaded robot (anything with a ``model`` attribute), or a ``pin.Model`` with a
        planar or free-flyer root joint and zero gravity.
    integrator : str
        ``"semi-implicit"`` (default) or ``"rk4"`` (:data:`INTEGRATORS`).
    project_momentum : bool
        Apply the momentum projection after each step (default). Switch it off only to
        measure the drift of the bare integrator.
    project_position : bool
        Put the CoM back on its straight line after each step (the module docstring; default
        off: the built-in cases' runs are those of before). It assumes no external force: a
        ``base_wrench`` may be a torque only (as the wheels' is).
    """

    def __init__(
        self,
        robot,
        *,
        integrator: str = "semi-implicit",
        project_momentum: bool = True,
        project_position: bool = False,
    ):
        if integrator not in INTEGRATORS:
            raise ParameterError(
                f"plant: integrator {integrator!r} unknown; valid choices: "
                f"{choices_text(INTEGRATORS)}"
            )
        self.robot = robot
        self.model = robot if isinstance(robot, pin.Model) else robot.model
        self.data = self.model.createData()
        self.root = root_kind(self.model)
        self.n_base, self._rows, self.n_linear = _ROOTS[self.root]
        self.integrator = integrator
        self.project_momentum = project_momentum
        self.project_position = project_position
        self._tau = np.zeros(self.model.nv)
        self._chart_block = chart_block(self.model)
        self.momentum0: np.ndarray | None = None  # the conserved rows of h_g
        self.mass = pin.computeTotalMass(self.model)
        # world displacement -> the root's translation entries of q (its parent frame's axes)
        self._to_root = np.array(self.model.jointPlacements[1].rotation).T[: self.n_linear]
        # the CoM's line, set by reset(): c(0), P / m [m/s] and the time since [s]
        self.com0 = np.zeros(3)
        self.com_rate = np.zeros(3)
        self.elapsed = 0.0

    def momentum(self, q, v) -> np.ndarray:
        """The conserved momentum: planar (P_x, P_y, L_z), free-flyer (P, L); P the linear
        momentum in the inertial frame [kg m/s], L the angular momentum about the system CoM in
        the inertial frame [kg m^2/s] (the root table's rows of Pinocchio's h_g, a copy).

        Parameters
        ----------
        %(q_v)s

        Returns
        -------
        ndarray
            The conserved rows, (3,) planar or (6,) free-flyer.
        """
        pin.computeCentroidalMomentum(self.model, self.data, q, v)
        return self.data.hg.np[self._rows]

    def momentum_rows(self, q_rows: np.ndarray, v_rows: np.ndarray) -> tuple:
        """(P, L) of :meth:`momentum` on N recorded states, q_rows (N, nq), v_rows (N, nv):
        P (N, n_linear) [kg m/s], L (N,) planar or (N, 3) [kg m^2/s] (a run computes them
        after its loop).

        Parameters
        ----------
        q_rows : ndarray, shape (N, nq)
            Recorded configurations.
        v_rows : ndarray, shape (N, nv)
            Recorded velocities.

        Returns
        -------
        P, L : ndarray
            Linear and angular momentum per row.
        """
        out = np.empty((len(q_rows), 6))  # h_g, its rows taken once at the end
        centroidal, model, data = pin.computeCentroidalMomentum, self.model, self.data
        for i, (q, v) in enumerate(zip(q_rows, v_rows, strict=True)):
            out[i] = centroidal(model, data, q, v).vector
        return self.split_momentum(out[:, self._rows])

    def split_momentum(self, momentum: np.ndarray) -> tuple:
        """(P, L) of :meth:`momentum`'s result, or of rows of them (last axis): P [kg m/s] the
        first ``n_linear`` entries, L [kg m^2/s] the rest (planar: the number L_z, free-flyer:
        a 3-vector; views)."""
        m = self.n_linear
        last = momentum.shape[-1]
        return momentum[..., :m], (momentum[..., m] if last == m + 1 else momentum[..., m:])

    def reset(self, q, v) -> None:
        """Set the momentum to be conserved from the initial state.

        Parameters
        ----------
        q, v : ndarray
            The initial state (Pinocchio convention).
        """
        self.momentum0 = self.momentum(q, v)
        self.com_rate = self.data.hg.linear / self.mass  # (a copy)
        self.com0 = pin.centerOfMass(self.model, self.data, q).copy()
        self.elapsed = 0.0

    def com_line(self) -> np.ndarray:
        """Where the CoM is on its straight line now: ``c(0) + (P / m) t`` [m], world frame, t
        the time :meth:`step` has advanced since :meth:`reset`.

        Returns
        -------
        ndarray, shape (3,)
            The CoM's position [m].
        """
        return self.com0 + self.elapsed * self.com_rate

    def _project_position(self, q: np.ndarray, com: np.ndarray) -> None:
        """Translate the root, in place in q, so that the CoM ``com`` (at q) is on its line."""
        q[: self.n_linear] += self._to_root @ (self.com_line() - com)

    def acceleration(self, q, v, u_m, base_wrench=None) -> np.ndarray:
        """Forward dynamics (ABA) with joint torques ``u_m`` [N m] and a free base (or a
        ``base_wrench`` on it, :meth:`step`).

        Parameters
        ----------
        %(q_v)s
        u_m : ndarray, shape (n,)
            Joint torques [N m].
        base_wrench : ndarray or None
            Generalized force on the root joint.

        Returns
        -------
        ndarray, shape (nv,)
            The acceleration (Pinocchio convention).
        """
        self._tau[self.n_base :] = u_m
        if base_wrench is None:
            return pin.aba(self.model, self.data, q, v, self._tau).copy()
        tau = self._tau.copy()
        tau[: self.n_base] = base_wrench
        return pin.aba(self.model, self.data, q, v, tau).copy()

    def with_robot(self, robot) -> Plant:
        """A plant of the same kind (integrator, projection) for another robot (the merged
        robot at a capture, :mod:`.capture_run`; with wheels, :mod:`.wheels_run`).

        Parameters
        ----------
        robot : Robot or pin.Model
            The new robot.

        Returns
        -------
        Plant
            The new plant (:meth:`reset` it).
        """
        return Plant(
            robot,
            integrator=self.integrator,
            project_momentum=self.project_momentum,
            project_position=self.project_position,
        )

    def step(self, q, v, u_m, dt: float, base_wrench=None) -> StepResult:
        """Advance (q, v) by ``dt`` [s] with joint torques ``u_m`` held constant.

        ``base_wrench``: a generalized force on the root joint held over the step (default
        none), Pinocchio's convention: free-flyer (force, torque) [N, N m] in the base frame,
        planar (f_x, f_y, torque_z) in the base frame; reaction wheels apply their torque on
        the bus through it (:mod:`.wheels`). It changes the momentum, so the projection, which
        restores :attr:`momentum0`, belongs to the caller then (``project_momentum=False`` and
        :meth:`project` with the momentum to keep).

        %(params_q_v_start_u_m)s
        dt : float
            Step [s].
        base_wrench : ndarray or None
            Generalized force on the root joint, held.

        %(returns_stepresult)s
        """
        if self.momentum0 is None:
            self.reset(q, v)
        model, data, tau = self.model, self.data, self._tau
        tau[self.n_base :] = u_m
        if base_wrench is not None:
            tau[: self.n_base] = base_wrench
        if self.integrator == "rk4":
            q_new, v_new, a = rkmk4_step(model, data, q, v, tau, dt, self._chart_block)
        else:
            out = np.empty((3, model.nv))  # rows: v+, dt v+, a (fresh: returned as views)
            _euler_velocity(v, pin.aba(model, data, q, v, tau), dt, out)
            q_new = pin.integrate(model, q, out[1])
            v_new, a = out[0], out[2]
        if self.project_position:  # (before the momentum's, done here or by the caller)
            self.elapsed += dt
            self._project_position(q_new, pin.centerOfMass(model, data, q_new))
        if self.project_momentum:
            _project_base(
                pin.computeCentroidalMap(model, data, q_new),
                v_new,
                self.momentum0,  # type: ignore[arg-type]  # set by reset() above
                self._rows,
            )
        if base_wrench is not None:
            tau[: self.n_base] = 0.0  # the free base again for the next call
        return StepResult(q_new, v_new, a)

    def advance(self, q, v, u_m, dt: float, substeps: int = 1, base_wrench=None) -> StepResult:
        """Advance (q, v) by one control step ``dt`` [s] in ``substeps`` plant steps of
        ``dt / substeps``, ``u_m`` [N m] (and ``base_wrench``, :meth:`step`) held. ``a`` is the
        acceleration at the start.

        %(params_q_v_start_u_m)s
        dt : float
            Control step [s].
        substeps : int
            Plant steps per control step.
        base_wrench : ndarray or None
            Generalized force on the root joint, held (:meth:`step`).

        %(returns_stepresult)s
        """
        if substeps < 1:
            raise ParameterError(f"plant: substeps must be >= 1, got {substeps}")
        if substeps == 1:  # (the step's own result: a is its start's)
            return self.step(q, v, u_m, dt, base_wrench)
        res = self.step(q, v, u_m, dt / substeps, base_wrench)
        a = res.a
        for _ in range(substeps - 1):
            res = self.step(res.q, res.v, u_m, dt / substeps, base_wrench)
        return StepResult(res.q, res.v, a)

    def state_status(self, q, v, rate_limit: float) -> int:
        """Whether a state can be stepped on: :data:`STATE_NONFINITE` when q or v [Pinocchio
        convention] holds a non-finite entry, :data:`STATE_BLOW_UP` when an angular rate
        (the entries of v after the ``n_linear`` linear base velocities) exceeds
        ``rate_limit`` [rad/s], else :data:`STATE_OK`.

        Parameters
        ----------
        %(q_v)s
        rate_limit : float
            Largest angular rate [rad/s].

        Returns
        -------
        int
            One of the ``STATE_*`` codes.
        """
        return _state_status(q, v, self.n_linear, rate_limit)

    @property
    def conserved_rows(self) -> np.ndarray:
        """The rows of Pinocchio's centroidal momentum h_g = (P, L) that :attr:`momentum0`
        holds and the projection keeps: planar (P_x, P_y, L_z), free-flyer all six (a copy:
        the root table's own array stays as it is)."""
        return self._rows.copy()

    def project(self, q, v, momentum=None) -> np.ndarray:
        """Base twist that restores the conserved momentum at q, joint rates unchanged (a new
        array; v is not modified). ``momentum``: the conserved rows to restore instead of
        :attr:`momentum0` (reaction wheels: :mod:`.wheels`).

        Parameters
        ----------
        %(q_v)s
        momentum : ndarray or None
            The conserved rows to restore; None: :attr:`momentum0`.

        Returns
        -------
        ndarray, shape (nv,)
            v with the base twist corrected.
        """
        out = np.array(v, dtype=float)
        target = self.momentum0 if momentum is None else np.asarray(momentum, dtype=float)
        _project_base(
            pin.computeCentroidalMap(self.model, self.data, q),
            out,
            target,  # type: ignore[arg-type]  # the run calls reset() first
            self._rows,
        )
        return out


def _compile_first_run() -> None:
    """Compile the plant's kernels with the argument types a run passes them: one step and
    one projection of a two-body chain on each root, made with the Pinocchio calls a run makes
    (the second process of a first run, :mod:`ffsm_pin.control._first_compile`)."""
    for root in (pin.JointModelPlanar(), pin.JointModelFreeFlyer()):
        model = pin.Model()
        base = model.addJoint(0, root, pin.SE3.Identity(), "base")
        model.appendBodyToJoint(base, pin.Inertia.FromBox(1.0, 1.0, 1.0, 1.0), pin.SE3.Identity())
        arm = model.addJoint(base, pin.JointModelRZ(), pin.SE3(np.eye(3), np.ones(3)), "arm")
        model.appendBodyToJoint(arm, pin.Inertia.FromBox(1.0, 1.0, 0.1, 0.1), pin.SE3.Identity())
        model.gravity.setZero()
        plant = Plant(model)
        q, v = pin.neutral(model), np.zeros(model.nv)
        plant.reset(q, v)
        plant.project(q, v)
        q, v, _ = plant.advance(q, v, np.zeros(1), 1e-3)
        plant.state_status(q, v, 1e4)


_first_compile.also_compile(__name__)  # a first run compiles the above in its second process
