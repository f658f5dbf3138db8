"""The compiled spatial control period (control/fast_spatial.py) against the numpy reference
(``backend="numpy"``): one period at random states of random chains, of the 9-joint arm
urdf/spatial9.urdf, for every scheme, task and null-space objective; 2 s closed loops of the
built-in spatial cases; every stop (status code) of the kernel."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.control.controller import CoordinatedController, Measurement
from ffsm_pin.control.funnel import FunnelParams
from ffsm_pin.control.gains import Gains, SingularityPolicy
from ffsm_pin.control.null_space import NullSpace
from ffsm_pin.errors import ParameterError, SimulationError
from ffsm_pin.model.spatial import SpatialBarycentricModel
from ffsm_pin.robot import load_spatial_robot
from ffsm_pin.robot.writer import SpatialBody, SpatialChain, SpatialLink, write_urdf
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.spec import ComponentReference, Harmonic, Reference
from ffsm_pin.sim.run import prepare, simulate

SPATIAL9 = Path(__file__).resolve().parents[2] / "urdf" / "spatial9.urdf"
OUTPUTS = ("u_m", "w_mc", "w_mc_dot", "err_b", "err_z", "w_tilde")
STATES = ("theta_z", "theta_d", "theta_b", "w_hat", "Y_df")


def _inertia(rng, scale):
    lam = rng.uniform(0.5, 1.0, 3) * scale
    Q = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
    inertia = Q @ np.diag(lam) @ Q.T
    return tuple(float(inertia[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))


@pytest.fixture(scope="module")
def robots(tmp_path_factory):
    """``robots(name)``: "random7", "random9" (random chains from ffsm_pin.robot.writer: any
    axes, CoMs off axis, full inertias) or "spatial9" (urdf/spatial9.urdf)."""
    folder = tmp_path_factory.mktemp("fast_spatial")
    cache = {}

    def make(name):
        if name in cache:
            return cache[name]
        if name == "spatial9":
            cache[name] = load_spatial_robot(SPATIAL9, "ee")
            return cache[name]
        n = int(name[len("random") :])
        rng = np.random.default_rng(7 * n)
        links = []
        for _ in range(n):
            axis = rng.normal(size=3)
            links.append(
                SpatialLink(
                    mass=rng.uniform(2, 8), inertia=_inertia(rng, 0.3),
                    com=rng.uniform(-0.2, 0.4, 3), origin_xyz=rng.uniform(-0.5, 0.5, 3),
                    origin_rpy=rng.uniform(-np.pi, np.pi, 3), axis=axis / np.linalg.norm(axis),
                )
            )  # fmt: skip
        base = SpatialBody(mass=80.0, inertia=_inertia(rng, 8.0), com=rng.uniform(-0.1, 0.1, 3))
        spec = SpatialChain(
            name=name, base=base, links=links,
            ee_xyz=rng.uniform(-0.2, 0.3, 3), ee_rpy=rng.uniform(-1, 1, 3),
        )  # fmt: skip
        cache[name] = load_spatial_robot(write_urdf(spec, folder / f"{name}.urdf"), "ee")
        return cache[name]

    return make


def _reference(n_task, rng):
    comps = [
        ComponentReference(
            c=float(rng.uniform(-0.5, 0.5)),
            cos=(Harmonic(float(rng.uniform(0.01, 0.05)), float(rng.uniform(0.1, 0.5))),),
            sin=(Harmonic(float(rng.uniform(0.01, 0.05)), float(rng.uniform(0.1, 0.5))),),
        )
        for _ in range(n_task)
    ]
    if n_task == 6:  # attitude references: small MRPs
        comps[3:] = [dataclasses.replace(c, c=float(rng.uniform(-0.2, 0.2))) for c in comps[3:]]
    task = "pose" if n_task == 6 else "position"
    return Reference(ee=tuple(comps), base_attitude=tuple(rng.uniform(-0.1, 0.1, 3)), task=task)


def _pair(robot, seed, task, scheme="ppc", null_space=None, funnel=50.0, threshold=1e-6,
          estimates=None, meas=None):  # fmt: skip
    """(compiled, numpy) controllers with the same random state and estimates, the first
    measurement, and the measurement of the next period."""
    rng = np.random.default_rng(seed)
    model = SpatialBarycentricModel(robot.geometry)
    n = robot.n_joints
    n_task = 6 if task == "pose" else 3
    q_b = mrp.shadow(rng.uniform(-0.6, 0.6, 3))
    q_m = rng.uniform(-np.pi, np.pi, n)
    w = rng.normal(scale=0.3, size=n + 3)
    theta_z = model.true_theta_z(rng.normal(scale=0.02, size=3))
    theta_d = np.array(model.theta_d)
    theta_b = np.array(model.true_theta_b(rng.normal(scale=0.5, size=3)))
    ref = _reference(n_task, rng)
    z_e = model.ee_pose(theta_z, q_b, q_m, rng.normal(scale=0.1, size=3))
    z_e_dot = np.concatenate((rng.normal(scale=0.1, size=3), rng.normal(scale=0.05, size=3)))
    known = scheme == "known-model"
    M = model.mass_matrix(theta_d, q_b, q_m) if known else None
    h = model.velocity_product(theta_d, q_b, q_m, w) if known else None
    meas0 = Measurement(0.3, q_b, q_m, w, z_e, z_e_dot, M, h)
    if estimates is None and not known:

        def perturb(x):
            return x * (1 + rng.uniform(-0.1, 0.1, x.shape))

        estimates = (perturb(theta_z), perturb(theta_d), perturb(theta_b))
    elif estimates is None:
        estimates = (theta_z, theta_d, theta_b)
    wide = FunnelParams((funnel,) * 3, (funnel / 50,) * 3, (0.2,) * 3, (0.8,) * 3)
    wide_z = FunnelParams(
        (funnel,) * n_task, (funnel / 50,) * n_task, (0.2,) * n_task, (0.8,) * n_task
    )
    out = []
    for backend in ("numba", "numpy"):
        ctrl = CoordinatedController(
            model, scheme=scheme, gains=Gains(k_b=0.3, k_z=0.2, k_de=1.0, k_d=2.0),
            funnel_b=wide, funnel_z=wide_z, reference=ref, base_attitude_ref=ref.base_attitude,
            singularity=SingularityPolicy(threshold=threshold),
            theta_z0=estimates[0], theta_d0=estimates[1], theta_b0=estimates[2],
            initial=meas0, task=task, null_space=null_space, backend=backend,
        )  # fmt: skip
        assert ctrl.backend == backend
        # mid-run filter states (Y_df = 0, w-hat = 0 at t = 0 would hide Eqs. 51-52)
        state_rng = np.random.default_rng(seed + 1000)
        ctrl.Y_df[...] = state_rng.normal(scale=0.05, size=ctrl.Y_df.shape)
        ctrl.w_hat[...] = w + state_rng.normal(scale=0.05, size=w.shape)
        out.append(ctrl)
    if meas is not None:
        meas0 = meas(meas0)
    return out[0], out[1], meas0


def _rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


# Agreement bound: both evaluate the same expressions in a different order (loops vs BLAS,
# complex step through the compiled H rows vs the real kernel plus Y_Mdot rows); the
# differences are rounding errors amplified by the condition of the 3x3 and (n+3) solves,
# 1e-13..1e-12 relative in the runs below. 1e-10 leaves room without hiding a wrong term
# (a missing term of dw_mc/dt changes u_m at the 1e-3..1 level).
RTOL = 1e-10
# Random states near a singularity of J_m-hat U-hat (sigma_min ~ 1e-4 m happens for random
# joint angles) amplify those rounding errors by ~1/sigma_min (and give u_m ~ 1e6 N m); the
# period comparison uses states with sigma_min above this [m] (damped ones: own test).
SIGMA_WELL = 0.005

SCHEMES = ("ppc", "no-ppc", "no-attitude", "known-model")
ROBOT_TASKS = (("random7", "position"), ("random9", "pose"), ("random9", "position"),
               ("spatial9", "pose"))  # fmt: skip


@pytest.mark.parametrize(("robot_name", "task"), ROBOT_TASKS)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_one_period_equals_numpy(robots, robot_name, task, scheme):
    robot = robots(robot_name)
    compared = 0
    for seed in range(12):
        fast, ref, meas = _pair(robot, seed, task, scheme)
        a, b = fast.step(meas, 0.01), ref.step(meas, 0.01)
        assert a.sigma_min == pytest.approx(b.sigma_min, rel=1e-9)
        if b.sigma_min < SIGMA_WELL:
            continue
        assert a.damping == b.damping == 0.0
        assert a.e is None and b.e is None  # no theta_d_true given: no e of Eq. (54)
        for name in OUTPUTS:
            assert _rel(getattr(a, name), getattr(b, name)) < RTOL, (name, seed)
        for name in STATES:  # the estimator states after the period
            assert _rel(getattr(fast, name), getattr(ref, name)) < RTOL, (name, seed)
        compared += 1
        if compared == 3:
            break
    assert compared == 3


@pytest.mark.parametrize("objective", ["manipulability", "joint-centering"])
@pytest.mark.parametrize("robot_name", ["random9", "spatial9"])
def test_null_space_equals_numpy(robots, robot_name, objective):
    """Position task on 9 joints: a 3-dimensional null space of J_m-hat U-hat."""
    robot = robots(robot_name)
    task = "position"
    center = np.linspace(-1, 1, robot.n_joints)  # away from the state's joint angles
    ns = NullSpace(objective=objective, gain=0.5, center=tuple(center))
    fast, ref, meas = _pair(robot, 11, task, "ppc", null_space=ns)
    plain, _, _ = _pair(robot, 11, task, "ppc")
    a, b = fast.step(meas, 0.01), ref.step(meas, 0.01)
    for name in OUTPUTS:
        assert _rel(getattr(a, name), getattr(b, name)) < RTOL, name
    # the term is active: the command differs from the paper's minimum-norm law
    assert _rel(a.w_mc, plain.step(meas, 0.01).w_mc) > 1e-6


def test_damped_period_equals_numpy(robots):
    """A threshold above sigma_min: damped least squares active in both backends."""
    fast, ref, meas = _pair(robots("random7"), 3, "position", threshold=50.0)
    with pytest.warns(UserWarning, match="singularity"):
        a = fast.step(meas, 0.01)
    with pytest.warns(UserWarning, match="singularity"):
        b = ref.step(meas, 0.01)
    assert a.damping > 0 and a.damping == pytest.approx(b.damping, rel=1e-12)
    for name in OUTPUTS:
        assert _rel(getattr(a, name), getattr(b, name)) < RTOL, name


def test_w_mc_dot_is_the_time_derivative(robots):
    """The compiled dw_mc/dt is the derivative of the compiled w_mc along the motion: a
    central difference of w_mc over +-h of (t, q_b, q_m, z_e) moved at the rates the period
    uses. dt = 1e9 makes the estimates' rates (new - old) / dt negligible (~1e-9)."""
    fast, _, meas = _pair(robots("random9"), 5, "pose")
    saved = [getattr(fast, n).copy() for n in STATES]
    q_b_rate = mrp.L_matrix(meas.q_b) @ meas.w[:3]  # Eq. (1)

    def at(h):
        for n, v in zip(STATES, saved, strict=True):
            getattr(fast, n)[...] = v
        m = meas._replace(
            t=meas.t + h, q_b=meas.q_b + h * q_b_rate, q_m=meas.q_m + h * meas.w[3:],
            z_e=meas.z_e + h * meas.z_e_dot,
        )  # fmt: skip
        return fast.step(m, 1e9)

    h = 1e-5
    fd = (at(h).w_mc - at(-h).w_mc) / (2 * h)
    # truncation ~ h^2 |d3 w_mc/dt3| ~ 1e-10, rounding ~ 1e-16 |w_mc| / h ~ 1e-11, estimate
    # rates ~ 1e-9: far below 1e-6 relative; a missing term of dw_mc/dt is of order 1
    assert _rel(fd, at(0.0).w_mc_dot) < 1e-6


@pytest.mark.parametrize(
    "case",
    ["spatial", "spatial-pose", "spatial-known-model", "spatial-no-ppc", "spatial-no-attitude"],
)
def test_closed_loop_equals_numpy(case):
    """2 s of the built-in case with both backends: the same trajectory."""
    results = []
    for backend in ("numba", "numpy"):
        scenario = dataclasses.replace(builtin_scenario(case), duration=2.0)
        setup = prepare(scenario)
        assert setup.controller.law.backend == "numba"  # the default for spatial robots
        setup.controller.law.backend = backend
        results.append(simulate(setup))
    a, b = results
    assert a.completed and b.completed and a.steps == b.steps
    for key in ("q", "v", "u_m", "w_mc", "w_hat", "err_z", "err_b", "theta_z_hat",
                "theta_d_hat", "theta_b_hat"):  # fmt: skip
        assert _rel(a[key], b[key]) < 1e-10, key


# ---------------------------------------------------------------------- stops (status codes)
def _both_stop(fast, ref, meas, cause, match=None):
    messages = []
    for ctrl in (fast, ref):
        with pytest.raises(SimulationError) as info:
            ctrl.step(meas, 0.01)
        assert info.value.cause == cause
        messages.append(str(info.value))
    if match is not None:
        assert match in messages[0]
    return messages


def test_stop_funnel_z(robots):
    def far(m):  # end-effector error component 1 far outside its funnel
        z = m.z_e.copy()
        z[1] += 10.0
        return m._replace(z_e=z)

    fast, ref, meas = _pair(robots("random9"), 1, "pose", funnel=0.5, meas=far)
    a, b = _both_stop(fast, ref, meas, "funnel", "component 1 (y)")
    assert a == b


def test_stop_funnel_b(robots):
    def far(m):  # attitude error component 2 far outside its funnel
        q_b = m.q_b.copy()
        q_b[2] = 0.9 if q_b[2] < 0 else -0.9
        return m._replace(q_b=q_b)

    fast, ref, meas = _pair(robots("random7"), 2, "position", funnel=0.5, meas=far)
    # the end-effector funnel must hold: put z_e on its reference
    meas = meas._replace(z_e=np.concatenate((fast.reference.ee_pose(meas.t), meas.z_e[3:])))
    a, b = _both_stop(fast, ref, meas, "funnel", "base attitude error component")
    assert a == b


def test_stop_h_collapse(robots):
    robot = robots("random7")
    model = SpatialBarycentricModel(robot.geometry)
    tb = np.concatenate(([0.1, 0.2, 0.3], 1e-20 * np.array(model.theta_d)))
    est = (np.array(model.true_theta_z(np.zeros(3))), np.array(model.theta_d), tb)
    fast, ref, meas = _pair(robot, 4, "position", estimates=est)
    _both_stop(fast, ref, meas, "estimate", "collapsed")


def test_stop_inertia_not_positive_definite(robots):
    robot = robots("random7")
    model = SpatialBarycentricModel(robot.geometry)
    td = np.array(model.theta_d)
    est = (np.array(model.true_theta_z(np.zeros(3))), -td, np.concatenate((np.zeros(3), td)))
    fast, ref, meas = _pair(robot, 4, "position", estimates=est)
    _both_stop(fast, ref, meas, "estimate", "not positive definite")


def test_stop_singular_base_rows(robots):
    """Known model with a measured M whose base block vanishes: Eq. (60a) has no solution."""

    def zero_base(m):
        M = np.eye(len(m.w))
        M[:3, :3] = 0.0
        return m._replace(M=M)

    fast, ref, meas = _pair(robots("random7"), 4, "position", "known-model", meas=zero_base)
    _both_stop(fast, ref, meas, "singular", "base rows of the filter are singular")


def test_stop_nonfinite(robots):
    def nan_h(m):
        h = m.h.copy()
        h[4] = np.nan
        return m._replace(h=h)

    fast, ref, meas = _pair(robots("random7"), 4, "position", "known-model", meas=nan_h)
    _both_stop(fast, ref, meas, "nonfinite", "non-finite")


def test_backend_choice(robots):
    """'auto' compiles for spatial robots; 'numpy' stays available; bad names refused."""
    fast, ref, _ = _pair(robots("random7"), 0, "position")
    assert (fast.backend, ref.backend) == ("numba", "numpy")
    with pytest.raises(ParameterError, match="valid choices"):
        CoordinatedController(
            fast.model, scheme="ppc", gains=Gains(), funnel_b=fast.funnel_b.params,
            funnel_z=fast.funnel_z.params, reference=fast.reference,
            base_attitude_ref=fast.q_bd, singularity=SingularityPolicy(),
            theta_z0=fast.theta_z, theta_d0=fast.theta_d, theta_b0=fast.theta_b,
            initial=fast._initial, task="position", backend="fortran",
        )  # fmt: skip
