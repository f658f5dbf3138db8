"""The coordinated controller on spatial robots (m2 = m3 = 3, MRP attitudes): the identities of
the paper that the kinematic law is built on, Eqs. (26) and (37), at random states of random
chains (position task on 7 joints, full-pose task on 9), L_b L_b^T of the MRP kinematics,
the exactness of the complex-step d w_mc / dt, and Eq. (55) along a short closed-loop run."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffsm_pin.attitude import mrp
from ffsm_pin.control.controller import CoordinatedController, check_feasibility
from ffsm_pin.control.funnel import FunnelParams
from ffsm_pin.control.gains import Gains, SingularityPolicy
from ffsm_pin.control.kinematic import KinematicInputs, attitude_matrix
from ffsm_pin.control.null_space import NullSpace
from ffsm_pin.errors import InfeasibleTaskError
from ffsm_pin.model.spatial import SpatialBarycentricModel
from ffsm_pin.robot import load_spatial_robot
from ffsm_pin.robot.writer import SpatialBody, SpatialChain, SpatialLink, write_urdf
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.spec import ComponentReference, Reference
from ffsm_pin.sim.run import Sensor, prepare, simulate


def _inertia(rng, scale):
    """(ixx, iyy, izz, ixy, ixz, iyz): principal moments in [0.5, 1] scale, random axes."""
    lam = rng.uniform(0.5, 1.0, 3) * scale
    Q = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
    inertia = Q @ np.diag(lam) @ Q.T
    return tuple(float(inertia[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """``chain(n, seed)``: a random spatial chain (any axes, CoMs off axis, full inertias)."""
    folder = tmp_path_factory.mktemp("spatial_control")
    cache = {}

    def make(n, seed):
        if (n, seed) not in cache:
            rng = np.random.default_rng(100 * n + seed)
            links = []
            for _ in range(n):
                axis = rng.normal(size=3)
                links.append(
                    SpatialLink(
                        mass=rng.uniform(2, 8),
                        inertia=_inertia(rng, 0.3),
                        com=rng.uniform(-0.2, 0.4, 3),
                        origin_xyz=rng.uniform(-0.5, 0.5, 3),
                        origin_rpy=rng.uniform(-np.pi, np.pi, 3),
                        axis=axis / np.linalg.norm(axis),
                    )
                )
            base = SpatialBody(mass=60.0, inertia=_inertia(rng, 5.0), com=rng.uniform(-0.1, 0.1, 3))
            spec = SpatialChain(
                name=f"c{n}_{seed}", base=base, links=links,
                ee_xyz=rng.uniform(-0.2, 0.3, 3), ee_rpy=rng.uniform(-1, 1, 3),
            )  # fmt: skip
            path = write_urdf(spec, folder / f"c{n}_{seed}.urdf")
            cache[(n, seed)] = load_spatial_robot(path, "ee")
        return cache[(n, seed)]

    return make


def _reference(n_task, rng):
    comps = [
        ComponentReference(c=float(rng.uniform(-0.5, 0.5)), cos=(), sin=()) for _ in range(n_task)
    ]
    # one harmonic per component so that dz_ed/dt != 0
    from ffsm_pin.scenario.spec import Harmonic

    comps = [
        dataclasses.replace(
            c, sin=(Harmonic(float(rng.uniform(0.01, 0.05)), float(rng.uniform(0.1, 0.5))),)
        )
        for c in comps
    ]
    task = "pose" if n_task == 6 else "position"
    if task == "pose":  # attitude references: small MRPs
        comps[3:] = [dataclasses.replace(c, c=float(rng.uniform(-0.2, 0.2))) for c in comps[3:]]
    return Reference(ee=tuple(comps), base_attitude=tuple(rng.uniform(-0.1, 0.1, 3)), task=task)


def _controller(robot, rng, task, scheme="ppc", null_space=None):
    """A controller at a random state with perturbed estimates and errors deep inside wide
    funnels (the identities hold for any psi, Phi; the funnels only have to be defined)."""
    model = SpatialBarycentricModel(robot.geometry)
    n = robot.n_joints
    q_b = mrp.shadow(rng.uniform(-0.6, 0.6, 3))
    q_m = rng.uniform(-np.pi, np.pi, n)
    w = rng.normal(scale=0.3, size=n + 3)
    theta_z = model.true_theta_z(rng.normal(scale=0.02, size=3))
    theta_d = np.array(model.theta_d)
    theta_b = model.true_theta_b(rng.normal(scale=0.5, size=3))

    def perturb(x):
        return x * (1 + rng.uniform(-0.05, 0.05, x.shape))

    n_task = 6 if task == "pose" else 3
    ref = _reference(n_task, rng)
    z_e = model.ee_pose(theta_z, q_b, q_m, rng.normal(scale=0.1, size=3))
    z_e_dot = np.concatenate((rng.normal(scale=0.1, size=3), rng.normal(scale=0.05, size=3)))
    from ffsm_pin.control.controller import Measurement

    meas = Measurement(0.0, q_b, q_m, w, z_e, z_e_dot)
    wide = FunnelParams((50.0,) * 3, (1.0,) * 3, (0.2,) * 3, (0.8,) * 3)
    wide_z = FunnelParams((50.0,) * n_task, (1.0,) * n_task, (0.2,) * n_task, (0.8,) * n_task)
    ctrl = CoordinatedController(
        model,
        scheme=scheme,
        gains=Gains(k_b=0.3, k_z=0.2),
        funnel_b=wide,
        funnel_z=wide_z,
        reference=ref,
        base_attitude_ref=ref.base_attitude,
        singularity=SingularityPolicy(threshold=1e-6),
        theta_z0=perturb(theta_z),
        theta_d0=perturb(theta_d),
        theta_b0=np.concatenate((perturb(theta_b[:3]), perturb(theta_d))),
        initial=meas,
        task=task,
        null_space=null_space,
    )
    return ctrl, meas


def _inputs(ctrl, meas, t=0.3):
    x = KinematicInputs(t, meas.q_b, meas.q_m, meas.z_e, ctrl.theta_b, ctrl.theta_z, meas.w[:3])
    return x


CASES = [(7, "position", 0), (7, "position", 1), (9, "pose", 0), (9, "pose", 1)]


@pytest.mark.parametrize(("n", "task", "seed"), CASES)
def test_eqs_26_and_37_hold_to_rounding(chain, n, task, seed):
    """H_bm-hat w_mc = A0-hat + k_b H_bb-hat L_b^T Phi_b psi_b (Eq. 26) and
    J_m-hat w_mc = -v0bar-hat + dz_ed/dt - k_z Phi_z psi_z (Eq. 37), at random states."""
    robot = chain(n, seed)
    rng = np.random.default_rng(seed)
    for _ in range(3):
        ctrl, meas = _controller(robot, rng, task)
        law, m = ctrl.kinematic, ctrl.model
        x = _inputs(ctrl, meas)
        w_mc, fb, fz, sigma, damping, _, _ = law.evaluate(x)
        assert damping == 0.0 and sigma > 1e-3
        H_bb, H_bm, A0 = m.momentum_matrices(ctrl.theta_b, meas.q_b, meas.q_m)
        L_b = mrp.L_matrix(meas.q_b)
        rhs26 = A0 + law.k_b * H_bb @ L_b.T @ (fb.Phi * fb.psi)
        np.testing.assert_allclose(H_bm @ w_mc, rhs26, rtol=0, atol=1e-10 * np.abs(rhs26).max())
        nt = ctrl.n_task
        _, J_m = m.jacobians(ctrl.theta_z, meas.q_b, meas.q_m)
        v0bar = np.zeros(nt)
        v0bar[:3] = ctrl.theta_z[:3]
        rhs37 = -v0bar + ctrl.reference.ee_rate(x.t) - law.k_z * fz.Phi * fz.psi
        np.testing.assert_allclose(J_m[:nt] @ w_mc, rhs37, rtol=0, atol=1e-9 * np.abs(rhs37).max())


def test_null_space_term_keeps_eqs_26_and_37(chain):
    """The null-space option on a spatial arm (spare joint of the 7-joint position task)
    changes w_mc but leaves Eqs. (26) and (37)."""
    robot = chain(7, 0)
    rng = np.random.default_rng(5)
    ctrl0, meas = _controller(robot, rng, "position")
    rng = np.random.default_rng(5)
    ctrl1, _ = _controller(robot, rng, "position", null_space=NullSpace("manipulability", 2.0))
    x0, x1 = _inputs(ctrl0, meas), _inputs(ctrl1, meas)
    w0 = ctrl0.kinematic.evaluate(x0)[0]
    w1 = ctrl1.kinematic.evaluate(x1)[0]
    assert np.linalg.norm(w1 - w0) > 1e-4
    m = ctrl1.model
    _, H_bm, _ = m.momentum_matrices(ctrl1.theta_b, meas.q_b, meas.q_m)
    _, J_m = m.jacobians(ctrl1.theta_z, meas.q_b, meas.q_m)
    np.testing.assert_allclose(H_bm @ w1, H_bm @ w0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(J_m[:3] @ w1, J_m[:3] @ w0, rtol=0, atol=1e-10)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3))
def test_L_b_L_b_T_is_a_multiple_of_identity(s):
    """L_b L_b^T = ((1 + s^T s) / 4)^2 E_3 (B B^T = (1 + s^T s)^2 E, R orthogonal): the
    paper's lambda_b >= 1/16 exists for MRPs."""
    s = mrp.shadow(np.array(s))
    L = attitude_matrix(s, 3)
    np.testing.assert_allclose(L @ L.T, ((1 + s @ s) / 4) ** 2 * np.eye(3), rtol=0, atol=1e-14)
    np.testing.assert_allclose(mrp.L_matrix(s), L, rtol=0, atol=0)
    # and L_b maps w_b (inertial) to ds/dt: a finite difference of the rotation
    w = np.array([0.3, -0.2, 0.5])
    h = 1e-6
    R = mrp.to_rotation(s)
    s_p = mrp.from_rotation(pin.exp3(w * h) @ R)
    s_m = mrp.from_rotation(pin.exp3(-w * h) @ R)
    if np.linalg.norm(s) < 0.99:  # away from the branch switch at |s| = 1
        np.testing.assert_allclose((s_p - s_m) / (2 * h), L @ w, rtol=0, atol=1e-8)


@pytest.mark.parametrize(("n", "task", "scheme"), [(7, "position", "ppc"), (9, "pose", "ppc"),
                                                   (7, "position", "no-attitude"),
                                                   (7, "position", "no-ppc")])  # fmt: skip
def test_wmc_dot_is_the_derivative_along_the_rates(chain, n, task, scheme):
    """The complex-step d w_mc / dt equals a central difference of w_mc along the same rates
    (t, q_b via dq_b/dt = L_b w_b, q_m, z_e, theta-hats); for Eq. (81) with w_b held, plus the
    returned sensitivity d w_mc / d w_b (compared by differencing in w_b)."""
    robot = chain(n, 0)
    rng = np.random.default_rng(11)
    ctrl, meas = _controller(robot, rng, task, scheme=scheme)
    law = ctrl.kinematic
    x = _inputs(ctrl, meas)
    rates = KinematicInputs(
        1.0, mrp.L_matrix(meas.q_b) @ meas.w[:3], meas.w[3:], meas.z_e_dot,
        rng.normal(scale=0.1, size=ctrl.theta_b.size) * np.abs(ctrl.theta_b),
        rng.normal(scale=0.1, size=ctrl.theta_z.size) * np.abs(ctrl.theta_z), 0.0,
    )  # fmt: skip
    cmd = law.command(x, rates)

    def at(eps, w_b=None):
        xe = KinematicInputs(
            *(np.asarray(a) + eps * np.asarray(r) for a, r in zip(x[:6], rates[:6], strict=True)),
            x.w_b if w_b is None else w_b,
        )
        return law.evaluate(xe)[0]

    h = 1e-5
    fd = (at(h) - at(-h)) / (2 * h)
    scale = np.abs(cmd.w_mc_dot).max()
    assert scale > 1e-3
    np.testing.assert_allclose(cmd.w_mc_dot, fd, rtol=0, atol=1e-6 * max(scale, 1.0))
    if scheme == "no-attitude":
        sens = np.column_stack(
            [(at(0, x.w_b + h * e) - at(0, x.w_b - h * e)) / (2 * h) for e in np.eye(3)]
        )
        np.testing.assert_allclose(cmd.dwmc_dwb, sens, rtol=0, atol=1e-7)
        assert np.abs(sens).max() > 1e-3
    else:
        np.testing.assert_array_equal(cmd.dwmc_dwb, 0.0)


def test_feasibility_names_the_joint_count():
    """m1 >= task components + m3: 6 joints for position + attitude, 9 for the pose."""
    check_feasibility(6, "ppc", n_task=3, m3=3)
    check_feasibility(9, "ppc", n_task=6, m3=3)
    check_feasibility(6, "no-attitude", n_task=6, m3=3)
    with pytest.raises(InfeasibleTaskError, match="at least 9 manipulator joints.*has 7"):
        check_feasibility(7, "ppc", n_task=6, m3=3)
    with pytest.raises(InfeasibleTaskError, match="at least 6 manipulator joints.*has 5"):
        check_feasibility(5, "known-model", n_task=3, m3=3)


@pytest.fixture(scope="module")
def short_run():
    """0.4 s of the built-in 'spatial' case with joint rates at t = 0 (so e(0) = M w(0) != 0)."""
    sc = builtin_scenario("spatial")
    ini = dataclasses.replace(
        sc.initial, joint_rates=(0.02, -0.015, 0.01, 0.02, -0.02, 0.015, 0.01)
    )
    sc = dataclasses.replace(sc, initial=ini, duration=0.4)
    setup = prepare(sc)
    return setup, simulate(setup)


def test_e_decays_as_eq55(short_run):
    """e = M w~ + Y_df theta_d~ (Eq. 54) obeys de/dt = -k_de e (Eq. 55): e(t) - e(0) exp(-k_de t)
    is the integration error alone, first order in dt (halving dt halves it, ratio 2 within
    15 %), and below 1 % of |e(0)| at the case's dt = 2 ms over 0.4 s."""
    setup, res = short_run
    assert res.completed, res.stop_reason
    k_de = setup.scenario.controller.lu_jia.gains.k_de
    half = simulate(prepare(dataclasses.replace(setup.scenario, dt=setup.scenario.dt / 2)))
    dev = []
    for r in (res, half):
        e, t = r["e"], r["t"]
        assert np.linalg.norm(e[0]) > 1e-3  # w-hat(0) = 0: e(0) = M w(0) != 0
        dev.append(np.max(np.abs(e - e[0] * np.exp(-k_de * t)[:, None])))
    assert dev[0] < 0.01 * np.abs(res["e"][0]).max()
    assert 1.7 < dev[0] / dev[1] < 2.3, dev
    # and e really decays: by exp(-0.4) over 0.4 s
    np.testing.assert_allclose(
        np.abs(res["e"][-1]).max() / np.abs(res["e"][0]).max(), np.exp(-0.4 * k_de), rtol=0.01
    )


def test_spatial_run_records_the_contract_shapes(short_run):
    """q_b, err_b, rho_b: 3 columns; z_e, err_z, rho_z: 3 (position task); P, L, F_r: 3;
    momentum exact to rounding (projection)."""
    setup, res = short_run
    s = res.signals
    for key, width in (("q_b", 3), ("err_b", 3), ("rho_b", 3), ("z_e", 3), ("err_z", 3),
                       ("rho_z", 3), ("z_e_d", 3), ("P", 3), ("L", 3), ("F_r", 3),
                       ("w", 10), ("u_m", 7)):  # fmt: skip
        assert s[key].shape[1:] == (width,), key
    assert np.all(np.linalg.norm(s["q_b"], axis=1) <= 1.0)
    np.testing.assert_allclose(s["L"], s["L"][0][None].repeat(len(s["L"]), 0), atol=1e-9)
    np.testing.assert_allclose(
        s["err_b"], s["q_b"] - np.array(setup.scenario.reference.base_attitude)
    )


def test_sensor_measures_the_spatial_state(short_run):
    """The sensor's q_b, w, z_e and dz_e/dt against SpatialState (Pinocchio), at a state of
    the run."""
    from ffsm_pin.model.state import State as SpatialState

    setup, res = short_run
    q, v = res.signals["q"][-1], res.signals["v"][-1]
    meas = Sensor(setup.robot, setup.model, full_model=False).measure(0.0, q, v)
    st_ = SpatialState(setup.robot).update(q, v)
    np.testing.assert_allclose(meas.q_b, st_.base_attitude, atol=1e-15)
    np.testing.assert_allclose(meas.w, st_.w, atol=1e-14)
    np.testing.assert_allclose(meas.z_e, st_.ee_pose, atol=1e-14)
    # dz_e/dt = J_b w_b + J_m w_m + v_0 (Eq. 3 with the CoM velocity)
    zdot = st_.J_b @ st_.w[:3] + st_.J_m @ st_.w[3:]
    zdot[:3] += st_.com_velocity
    np.testing.assert_allclose(meas.z_e_dot, zdot, atol=1e-12)
