"""Dry run (``python -m ffsm_pin.sim --check``): what decides whether a run can work.

Nothing is simulated. The checks are necessary conditions estimated at t = 0, not a proof
that the run succeeds: a run that passes may still leave a funnel later.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import FfsmError
from ..scenario.spec import Scenario


@dataclass(frozen=True)
class CheckReport:
    """What ``--check`` measured and what speaks against the run.

    Attributes
    ----------
    name : str
        Scenario name.
    sigma_min : float | None
        Smallest singular value of J_m-hat U-hat (or J_m-hat) at t = 0 [-].
    threshold : float | None
        The run's singularity threshold (``controller.singularity.threshold``, the
        performance specification's).
    reach_horizon : float | None
        Time the reference leaves the reach under the CoM drift [s]; None if never.
    authority : float | None
        Spatial only: largest base rotation the arm can buy with its joint travel [rad],
        ``sigma_max(H_bb^-1 H_bm) * |joint travel|``.
    attitude_error : float | None
        Spatial only: rotation angle of the initial base attitude error [rad].
    problems : list[str]
        One line per reason the run cannot work; empty when nothing speaks against it.
    """

    name: str
    sigma_min: float | None = None
    threshold: float | None = None
    reach_horizon: float | None = None
    authority: float | None = None
    attitude_error: float | None = None
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when no problem was found."""
        return not self.problems


def _joint_travel(robot) -> np.ndarray:
    """Range of each actuated joint [rad]: URDF limits, pi when there are none."""
    n = robot.n_joints
    lo = np.asarray(robot.model.lowerPositionLimit, dtype=float)
    hi = np.asarray(robot.model.upperPositionLimit, dtype=float)
    lo, hi = lo[-n:], hi[-n:]
    travel = hi - lo
    good = np.isfinite(travel) & (travel > 0) & (travel < 1e6)
    return np.where(good, np.minimum(travel, 2 * np.pi), np.pi)


def check(scenario: Scenario) -> CheckReport:
    """Build the scenario (``prepare``) and evaluate the t = 0 conditions; never simulates."""
    from ..control.gains import GainWarning
    from ..control.kinematic import task_errors  # heavy imports here
    from ..model import State
    from .measurement import Sensor
    from .reach import ReachWarning
    from .setup import prepare

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("ignore", ReachWarning)
            warnings.simplefilter("always", GainWarning)
            setup = prepare(scenario)
    except FfsmError as exc:
        return CheckReport(scenario.name, problems=[str(exc)])
    # gains that violate a discrete-time condition (a warning on a run) are problems here;
    # any other warning is shown as it would have been
    problems: list[str] = [str(w.message) for w in caught if w.category is GainWarning]
    for w in caught:
        if w.category is not GainWarning:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    m3 = setup.model.m3
    meas = Sensor(setup.robot, setup.model, full_model=False).measure(0.0, setup.q0, setup.v0)
    # distance to singularity, for controllers that invert a task Jacobian
    singular_value = getattr(setup.controller, "singular_value", None)
    sigma = None if singular_value is None else float(singular_value(meas))
    thr = float(scenario.performance.singularity_threshold)
    if sigma is not None and not sigma > thr:
        problems.append(
            f"singular start: sigma_min of the task Jacobian at t = 0 is {sigma:.4g} <= "
            f"controller.singularity.threshold = {thr:g}; bend the arm (initial.joints away "
            "from a stretched or folded pose)"
        )
    horizon = setup.reach_horizon
    if horizon is not None:
        problems.append(
            f"reference out of reach: it leaves the arm's reach at t = {horizon:.2f} s of "
            f"{scenario.duration:g} s; move reference.ee closer to the base or shorten duration"
        )
    authority = att = None
    if m3 == 3:
        st: Any = State(setup.robot).update(setup.q0, setup.v0)
        gain = np.linalg.svd(np.linalg.solve(st.H_bb, st.H_bm), compute_uv=False)
        authority = float(gain[0] * np.linalg.norm(_joint_travel(setup.robot)))
        q_bd = np.array(setup.scenario.reference.base_attitude, dtype=float)  # resolved
        err_b, _ = task_errors(setup.scenario.reference, q_bd, 0.0, meas.q_b, meas.z_e, m3)
        att = float(4 * np.arctan(np.linalg.norm(err_b)))  # MRP -> rotation angle
        if att > authority:
            problems.append(
                f"attitude error beyond the arm's authority: |err_b(0)| = {att:.3g} rad but "
                f"the arm can rotate the base by at most {authority:.3g} rad "
                "(sigma_max(H_bb^-1 H_bm) x joint travel); set reference.base_attitude nearer "
                "initial.base_attitude or use a lighter satellite / heavier arm"
            )
    return CheckReport(scenario.name, sigma, thr, horizon, authority, att, problems)
