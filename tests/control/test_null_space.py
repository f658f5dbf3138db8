"""The null-space option (beyond the paper): ``xi_n = (E - A^+ A) k_s grad mu`` added to Eq. (36).

Checked at random states of the 5-link off-axis robot (one spare joint), with perturbed
estimates, on both backends (the numpy reference and the compiled numba kernel):

* it leaves Eq. (26) (H_bm-hat w_mc = a_b) and Eq. (37) (J_m-hat w_mc = target) exactly as they
  are where the inverse is undamped (both checked with a_b and the target written out), and
  the change of w_mc lies in the null space of
  B = [H_bm-hat; J_m-hat], and it *is* k_s times the orthogonal projection of grad mu onto that
  null space (U (E - A^+ A) = E - B^+ B, because null(A) = null(B) + range(H_bm^T)), with
  grad mu recomputed here independently (closed form for joint-centering; for
  manipulability mu from singular values and a 5-point stencil);
* dw_mc/dt (complex step) equals a central difference of w_mc along the rates;
* objective "none" is the paper's law; bad input is refused.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.control.kinematic import KinematicInputs
from ffsm_pin.control.lu_jia_params import LuJiaParams
from ffsm_pin.control.null_space import OBJECTIVES, NullSpace
from ffsm_pin.errors import FfsmError, ParameterError, ScenarioError
from ffsm_pin.scenario.file import builtin_path, load_scenario, scenario_from_toml
from ffsm_pin.scenario.spec import (
    ComponentReference,
    ControllerSpec,
    Estimates,
    Harmonic,
    InitialCondition,
    Performance,
    Reference,
    RobotSpec,
    Scenario,
)
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import prepare, simulate

DATA = Path(__file__).resolve().parents[1] / "data"
REPO = Path(__file__).resolve().parents[2]
# the shipped robot, by path until ffsm_pin.urdf is installed from this tree
PLANAR5_URDF = REPO / "urdf" / "ffsm_planar5.urdf"
GAINS = {"manipulability": 0.7, "joint-centering": 0.4}


def _scenario(ns: NullSpace, scheme: str = "ppc", seed: int = 2) -> Scenario:
    init = InitialCondition(
        base_pose=(0.0, 0.0, 0.1),
        joints=(0.8, 0.8, -0.8, 0.8, 0.8),
        joint_rates=(0.0,) * 5,
        com_at_origin=True,
        com_velocity=(0.0, 0.0),
        angular_momentum=0.1,
    )
    ref = Reference(
        ee=(
            ComponentReference(0.3, cos=(Harmonic(0.1, 0.3),)),
            ComponentReference(3.9, sin=(Harmonic(0.1, 0.3),)),
            ComponentReference(2.4, cos=(Harmonic(0.02, 0.3),)),
        )
    )
    ctrl = ControllerSpec(
        lu_jia=LuJiaParams(scheme=scheme, null_space=ns),
        estimates=Estimates(initial="perturbed", spread=0.3, seed=seed),
    )
    # funnels wide enough for any random state below
    perf = Performance()
    perf = dataclasses.replace(
        perf,
        funnel_b=dataclasses.replace(perf.funnel_b, rho0=(50.0,)),
        funnel_z=dataclasses.replace(perf.funnel_z, rho0=(50.0, 50.0, 50.0)),
    )
    robot = RobotSpec(urdf=str(DATA / "planar5_offaxis.urdf"))
    return Scenario(robot, init, ref, ctrl, performance=perf)


def _controller(ns: NullSpace, backend: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(_scenario(ns))
    ctrl = setup.controller.law
    if backend == "numpy":
        ctrl.backend = "numpy"
    assert ctrl.backend == backend
    return setup, ctrl


def _random_states(model, theta_b, theta_z, n_states=12, seed=0):
    """Random (x, rates) with theta estimates moved by 20 %; skips near-singular draws."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    out = []
    while len(out) < n_states:
        q_b = rng.uniform(-0.5, 0.5)
        q_m = np.array([0.8, 0.8, -0.8, 0.8, 0.8]) + rng.uniform(-0.6, 0.6, n)
        x = KinematicInputs(
            t=rng.uniform(0.0, 10.0),
            q_b=q_b,
            q_m=q_m,
            z_e=np.array([0.3, 3.9, 2.4]) + rng.uniform(-0.3, 0.3, 3),
            theta_b=theta_b * (1 + 0.2 * rng.uniform(-1, 1, theta_b.size)),
            theta_z=theta_z * (1 + 0.2 * rng.uniform(-1, 1, theta_z.size)),
            w_b=rng.normal(scale=0.05),
        )
        rates = KinematicInputs(
            1.0, rng.normal(scale=0.05), rng.normal(scale=0.2, size=n),
            rng.normal(scale=0.1, size=3), rng.normal(scale=0.1, size=theta_b.size),
            rng.normal(scale=0.1, size=theta_z.size), 0.0,
        )  # fmt: skip
        out.append((x, rates))
    return out


def _w_mc(ctrl, x: KinematicInputs, rates: KinematicInputs | None = None):
    """(w_mc, dw_mc/dt, damping) from the controller's backend at x (rates: complex step)."""
    if rates is None:
        rates = KinematicInputs(0.0, 0.0, 0 * x.q_m, 0 * x.z_e, 0 * x.theta_b, 0 * x.theta_z, 0.0)
    if ctrl.backend == "numpy":
        kc = ctrl.kinematic.command(x, rates)
        return kc.w_mc, kc.w_mc_dot, kc.damping
    from ffsm_pin.control import fast, kernels

    hj = 1j * 1e-30
    # the period's bundles: the model's constants, the law's, the reference's, the null space
    w_c, _, _, damping, _, _, _, status, _ = fast.kinematic_law(
        ctrl._geo, ctrl._law, ctrl._ref, ctrl._law.null_space,
        x.t + hj * rates.t, x.q_b + hj * rates.q_b, x.q_m + hj * rates.q_m,
        x.z_e + hj * rates.z_e, x.theta_b + hj * rates.theta_b,
        x.theta_z + hj * rates.theta_z, x.w_b + 0j,
    )  # fmt: skip
    assert status == kernels.STATUS_OK
    return w_c.real.copy(), w_c.imag / 1e-30, damping


def _sigma_min(model, x):
    _, J_m = model.jacobians(x.theta_z, x.q_b, x.q_m)
    _, H_bm, _ = model.momentum_matrices(x.theta_b, x.q_b, x.q_m)
    U = np.eye(model.n_joints) - H_bm.T @ H_bm / (H_bm @ H_bm.T)
    return np.linalg.svd(J_m @ U, compute_uv=False)[-1], J_m, H_bm


def _mu_svd(model, x, q_m):
    """Manipulability as the product of the singular values of A (not a determinant)."""
    _, J_m = model.jacobians(x.theta_z, x.q_b, q_m)
    _, H_bm, _ = model.momentum_matrices(x.theta_b, x.q_b, q_m)
    U = np.eye(model.n_joints) - H_bm.T @ H_bm / (H_bm @ H_bm.T)
    return np.prod(np.linalg.svd(J_m @ U, compute_uv=False))


def _grad_reference(objective, model, x, center):
    if objective == "joint-centering":
        return center - x.q_m
    h = 1e-3  # 5-point stencil: truncation h^4 mu^(5) / 30 ~ 1e-13 for angles of order 1 rad
    g = np.zeros(model.n_joints)
    for j in range(model.n_joints):
        e = np.zeros(model.n_joints)
        e[j] = h
        f = [_mu_svd(model, x, x.q_m + k * e) for k in (-2, -1, 1, 2)]
        g[j] = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h)
    return g


@pytest.mark.parametrize("backend", ["numpy", "numba"])
@pytest.mark.parametrize("objective", ["manipulability", "joint-centering"])
def test_term_keeps_eqs_26_and_37_and_is_the_projected_gradient(objective, backend):
    setup, paper = _controller(NullSpace(), backend)
    _, ctrl = _controller(NullSpace(objective, GAINS[objective]), backend)
    model = setup.model
    center = np.asarray(setup.q0[4:])  # default centre: the initial joints
    np.testing.assert_array_equal(ctrl.kinematic.center, center)
    checked = 0
    for x, _ in _random_states(model, paper.theta_b, paper.theta_z):
        w0, _, d0 = _w_mc(paper, x)
        w1, _, d1 = _w_mc(ctrl, x)
        sigma, J_m, H_bm = _sigma_min(model, x)
        if sigma < 2 * setup.scenario.performance.singularity_threshold:
            continue  # damped (or close): Eqs. (26), (37) are not claimed there
        assert d0 == d1 == 0.0
        checked += 1
        delta = w1 - w0
        scale = np.abs(w0).max() + np.abs(w1).max()
        # Eq. (26) and Eq. (37) unchanged: the term lies in null([H_bm; J_m])
        assert abs(H_bm @ delta)[0] < 1e-12 * scale * np.abs(H_bm).max()
        assert np.abs(J_m @ delta).max() < 1e-12 * scale * np.abs(J_m).max()
        # the identities themselves, right-hand sides written out from Eqs. (25) and (37)
        law = ctrl.kinematic
        err_b, err_z = law.errors(x.t, x.q_b, x.z_e)
        fb, fz = law.funnel_b.evaluate(x.t, err_b), law.funnel_z.evaluate(x.t, err_z)
        H_bb, _, A0 = model.momentum_matrices(x.theta_b, x.q_b, x.q_m)
        a_b = A0 + law.k_b * H_bb[0, 0] * fb.Phi * fb.psi  # Eq. (25)
        target = law.reference.ee_rate(x.t) - law.k_z * fz.Phi * fz.psi
        target[:2] -= x.theta_z[:2]  # - v0bar-hat
        np.testing.assert_allclose(H_bm @ w1, a_b, rtol=1e-10, atol=1e-12)  # Eq. (26)
        np.testing.assert_allclose(J_m @ w1, target, rtol=1e-10, atol=1e-12)  # Eq. (37)
        # ... and the change is k_s times the orthogonal projection of grad mu onto null(B)
        B = np.vstack((H_bm, J_m))
        P = np.eye(model.n_joints) - np.linalg.pinv(B) @ B
        expected = GAINS[objective] * P @ _grad_reference(objective, model, x, center)
        assert np.linalg.norm(expected) > 1e-3  # the term does something here
        np.testing.assert_allclose(delta, expected, rtol=0, atol=1e-7 * np.abs(expected).max())
    assert checked >= 8


@pytest.mark.parametrize("backend", ["numpy", "numba"])
@pytest.mark.parametrize("objective", ["manipulability", "joint-centering"])
def test_w_mc_dot_is_the_exact_derivative(objective, backend):
    """Complex-step dw_mc/dt equals a difference quotient of w_mc along the same rates.

    5-point stencil, step h = 2e-2: truncation ~h^4 |w^(5)| / 30 ~ 5e-9 |w^(5)|, and |w^(5)|
    is small (rates of 0.1-0.2, time scales of 3-5 s). Rounding: the manipulability gradient
    inside w_mc is itself a difference quotient (step 1e-5), so w_mc carries an absolute noise
    ~k_s 1e-16 mu / 1e-5 ~ 1e-10 (mu of a few m^2 here), which the stencil amplifies by
    18 / (12 h) = 75 to ~1e-8. Bound: 1e-6 relative to the largest component, but not below
    5e-8 absolute (a plain central difference with h = 1e-6 would see ~1e-5 of noise)."""
    setup, ctrl = _controller(NullSpace(objective, GAINS[objective]), backend)
    h = 2e-2
    for x, r in _random_states(setup.model, ctrl.theta_b, ctrl.theta_z, n_states=6, seed=1):
        _, dw, damping = _w_mc(ctrl, x, r)
        if damping > 0:
            continue

        def shifted(s, x=x, r=r):
            moved = (np.asarray(a) + s * np.asarray(b) for a, b in zip(x, r, strict=True))
            return KinematicInputs(*moved)

        ws = []
        for k in (-2, -1, 1, 2):
            wk, _, dk = _w_mc(ctrl, shifted(k * h)._replace(w_b=x.w_b))
            assert dk == 0.0
            ws.append(wk)
        fd = (ws[0] - 8 * ws[1] + 8 * ws[2] - ws[3]) / (12 * h)
        np.testing.assert_allclose(dw, fd, rtol=0, atol=max(1e-6 * np.abs(fd).max(), 5e-8))


def test_none_is_the_paper_law():
    """Objective "none" (the default) takes the paper's code path: the same w_mc, to the bit,
    as a controller built without the option, and gain 0 adds exactly nothing."""
    setup, paper = _controller(NullSpace(), "numpy")
    _, none = _controller(NullSpace("none", 5.0), "numpy")
    _, zero = _controller(NullSpace("manipulability", 0.0), "numpy")
    assert paper.null_space == ControllerSpec().lu_jia.null_space
    for x, _ in _random_states(setup.model, paper.theta_b, paper.theta_z, n_states=4):
        w0 = _w_mc(paper, x)[0]
        np.testing.assert_array_equal(_w_mc(none, x)[0], w0)
        np.testing.assert_array_equal(_w_mc(zero, x)[0], w0)


def test_explicit_center():
    center = (0.5, 0.5, -0.5, 0.5, 0.5)
    _, ctrl = _controller(NullSpace("joint-centering", 1.0, center), "numpy")
    np.testing.assert_array_equal(ctrl.kinematic.center, center)
    assert not ctrl.kinematic.center.flags.writeable


# ------------------------------------------------------------------------------ bad input
def test_bad_parameters():
    with pytest.raises(ParameterError) as info:
        NullSpace("manipulabilty")
    for name in OBJECTIVES:
        assert name in str(info.value)
    with pytest.raises(ParameterError, match="gain"):
        NullSpace("manipulability", -1.0)
    with pytest.raises(ParameterError, match="gain"):
        NullSpace("manipulability", float("nan"))
    with pytest.raises(FfsmError, match="5 joints"):
        prepare(_scenario(NullSpace("joint-centering", 1.0, (0.0, 0.0))))
    with pytest.raises(FfsmError, match="no-attitude"):
        prepare(_scenario(NullSpace("manipulability", 1.0), scheme="no-attitude"))


SCEN = """
[robot]
urdf = "{urdf}"
[initial]
base_pose = [0.0, 0.0, 0.1]
joints = [0.8, 0.8, -0.8, 0.8, 0.8]
com_velocity = [0.0, 0.0]
angular_momentum = 0.1
[reference]
ee = [ {{ c = 0.3 }}, {{ c = 3.9 }}, {{ c = 2.4 }} ]
{extra}
"""


def _from_toml(extra: str):
    return scenario_from_toml(SCEN.format(urdf=DATA / "planar5_offaxis.urdf", extra=extra))


def test_scenario_keys_round_trip():
    assert _from_toml("").controller.lu_jia.null_space == NullSpace()
    for extra, expected in (
        ('[controller.null_space]\nobjective = "manipulability"\ngain = 0.5',
         NullSpace("manipulability", 0.5)),
        ('[controller.null_space]\nobjective = "joint-centering"\ngain = 2\n'
         "center = [0.1, 0.2, 0.3, 0.4, 0.5]",
         NullSpace("joint-centering", 2.0, (0.1, 0.2, 0.3, 0.4, 0.5))),
    ):  # fmt: skip
        sc = _from_toml(extra)
        assert sc.controller.lu_jia.null_space == expected
        assert scenario_from_toml(scenario_to_toml(sc)).controller.lu_jia.null_space == expected
    # the paper's law writes no table (saved scenario files of existing cases unchanged)
    assert "null_space" not in scenario_to_toml(_from_toml(""))


@pytest.mark.parametrize(
    "extra, message",
    [
        ('objective = "manipulabilty"', "did you mean 'manipulability'"),
        ('objective = "manipulabilty"', "valid choices"),
        ("gain = -0.1", "controller.null_space.gain"),
        ('gain = "1"', "expected a number"),
        ('objective = "manipulability"\ncenter = [0.0]', "only used with objective"),
        ("gian = 1.0", "did you mean 'gain'"),
    ],
)
def test_scenario_errors(extra, message):
    with pytest.raises(ScenarioError, match=message) as info:
        _from_toml("[controller.null_space]\n" + extra)
    assert str(info.value).count("\n") == 0


# ------------------------------------------------------------------------------ planar5
def _planar5(seed: int | None, ns: NullSpace | None = None) -> Scenario:
    sc = load_scenario(builtin_path("planar5"))
    c = sc.controller
    est = Estimates("true") if seed is None else dataclasses.replace(c.estimates, seed=seed)
    lu_jia = dataclasses.replace(c.lu_jia, null_space=ns or NullSpace())
    c = dataclasses.replace(c, estimates=est, lu_jia=lu_jia)
    robot = dataclasses.replace(sc.robot, urdf=str(PLANAR5_URDF))
    return dataclasses.replace(sc, robot=robot, controller=c)


def test_planar5_scenario_shape():
    sc = _planar5(0)
    assert sc.controller.estimates.initial == "perturbed"
    assert sc.controller.estimates.spread == 0.3
    assert sc.controller.lu_jia.null_space == NullSpace()  # the paper's scheme
    setup = prepare(sc)
    assert setup.robot.n_joints == 5 and not setup.model.layout.collinear


@pytest.mark.slow
def test_planar5_is_a_fair_test_with_true_parameters():
    """With the true parameters the paper's law keeps both funnels for 30 s and the arm stays
    away from singular poses (sigma_min above the damping threshold throughout): the scenario
    is not degenerate."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(prepare(_planar5(None)))
    assert res.completed, res.stop_reason
    assert res.funnel_inside_b.all() and res.funnel_inside_z.all()
    assert np.all(res["damping"] == 0)
    assert res["sigma_min"].min() > _planar5(None).performance.singularity_threshold


@pytest.mark.slow
@pytest.mark.parametrize("objective", ["manipulability", "joint-centering"])
def test_planar5_closed_loop_with_the_option(objective):
    """A 30 s closed loop with the option and perturbed estimates completes with both
    funnels kept (the term does not disturb the paper's error dynamics, Eqs. 26, 37)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(prepare(_planar5(0, NullSpace(objective, GAINS[objective]))))
    assert res.completed, res.stop_reason
    assert res.funnel_inside_b.all() and res.funnel_inside_z.all()
