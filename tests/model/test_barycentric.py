"""The parametric (barycentric) model against Pinocchio, finite differences and the paper.

Property tests run with hypothesis, derandomized (the same examples on every run); every
example builds its states from a numpy Generator seeded by the drawn integer.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffsm_pin.errors import ParameterError
from ffsm_pin.model.planar import BarycentricModel
from ffsm_pin.model.state import State as FloatingBaseState
from ffsm_pin.robot import load_robot
from ffsm_pin.robot.writer import PlanarBody, PlanarChain, PlanarLink, write_urdf

# Barycentric closed form vs Pinocchio's algorithms: both are exact formulas evaluated in double
# precision (observed differences ~1e-14 of the magnitude); 1e-10 of max(|expected|, 1) leaves
# room for conditioning of the Schur complement and for 8-link chains.
TOL = 1e-10
# 5-point central differences with h = 1e-3 of smooth trigonometric functions of O(1)
# frequency: truncation ~ h^4 / 30 * |f^(5)| and rounding ~ 1e-16 |f| / h, both ~1e-12 of |f|.
FD_TOL = 1e-9

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)
N_LINKS = st.integers(min_value=4, max_value=8)
PROPERTY = settings(derandomize=True, max_examples=30, deadline=None)
N_STATES = 3  # random states per example


def rel_err(actual, expected, floor=1.0):
    """max |actual - expected| / max(max |expected|, floor)."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    return float(np.abs(actual - expected).max() / max(np.abs(expected).max(), floor))


def derivative(f, h=1e-3):
    """d/dt f(t) at t = 0, 5-point central stencil (errors: see FD_TOL)."""
    return (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)


def angle_diff(a, b):
    return math.remainder(a - b, 2 * math.pi)


def split(q):
    """Pinocchio q -> (q_b, q_m)."""
    return math.atan2(q[3], q[2]), np.array(q[4:])


# ----------------------------------------------------------------------------- robot variants
def tilted(chain: PlanarChain, rng: np.random.Generator) -> PlanarChain:
    """Rotate every body's CoM and child joint (tip) about the body's joint by a random angle:
    a collinear chain stays collinear, but along lines that are not the x axes."""

    def rot(vec, a):
        c, s = math.cos(a), math.sin(a)
        return (c * vec[0] - s * vec[1], s * vec[0] + c * vec[1])

    a0 = rng.uniform(-1.0, 1.0)
    links = []
    for link in chain.links:
        a = rng.uniform(-1.0, 1.0)
        links.append(dataclasses.replace(link, com=rot(link.com, a), tip=rot(link.tip, a)))
    return dataclasses.replace(
        chain,
        name=chain.name + "_tilted",
        base=dataclasses.replace(chain.base, com=rot(chain.base.com, a0)),
        mount=rot(chain.mount, a0),
        links=tuple(links),
    )


def with_yaws(text: str, yaws: dict[str, float]) -> str:
    """Set the yaw of the named joints' origins in a generated URDF."""
    for joint, yaw in yaws.items():
        pattern = rf'(<joint name="{joint}".*?<origin [^>]*rpy=")0 0 0(")'
        text, count = re.subn(pattern, rf"\g<1>0 0 {yaw!r}\g<2>", text, count=1, flags=re.S)
        assert count == 1, joint
    return text


@pytest.fixture(scope="module")
def yawed_robots(data_dir, tmp_path_factory):
    """The 5-link test robots with fixed yaws in joints 1, 3 and the end-effector frame."""
    folder = tmp_path_factory.mktemp("yawed")
    robots = []
    for name in ("planar5_collinear", "planar5_offaxis"):
        text = (data_dir / f"{name}.urdf").read_text()
        path = folder / f"{name}_yawed.urdf"
        path.write_text(with_yaws(text, {"joint1": 0.3, "joint3": -0.8, "ee": 0.55}))
        robots.append(load_robot(path))
    return robots


# ----------------------------------------------------------------------------- the comparison
def check_against_pinocchio(robot, seed, random_state, n_states=N_STATES):
    """Every model quantity with the true parameters equals FloatingBaseState's at random
    states (module docstring of ffsm_pin.model.planar; docs/model.md sections 1-2)."""
    bm = BarycentricModel(robot.geometry)
    fbs = FloatingBaseState(robot)
    data = robot.model.createData()
    rng = np.random.default_rng(seed)
    for _ in range(n_states):
        q, v = random_state(robot, rng)
        fbs.update(q, v)
        qb, qm = split(q)
        w = fbs.w
        L = fbs.angular_momentum
        theta_z = bm.true_theta_z(fbs.com_velocity)
        theta_b = bm.true_theta_b(L)

        assert rel_err(bm.mass_matrix(bm.theta_d, qb, qm), fbs.M) < TOL
        assert rel_err(bm.velocity_product(bm.theta_d, qb, qm, w), fbs.h) < TOL

        H_bb, H_bm, A0 = bm.momentum_matrices(theta_b, qb, qm)
        assert H_bb.shape == (1, 1) and H_bm.shape == (1, robot.n_joints)
        assert rel_err(H_bb, fbs.H_bb) < TOL
        assert rel_err(H_bm, fbs.H_bm) < TOL
        assert A0 == L
        # Eq. (15): Y_b theta_b = H_bb w_b + H_bm w_m - A_0 = 0 (relative to |H w|, |A_0|)
        residual = bm.Y_b(qb, qm, w) @ theta_b
        assert residual.shape == (1,)
        assert abs(residual[0]) < TOL * max(1.0, abs(L), float(np.abs(fbs.M[0]) @ np.abs(w)))

        J_b, J_m = bm.jacobians(theta_z, qb, qm)
        assert rel_err(J_b, fbs.J_b) < TOL
        assert rel_err(J_m, fbs.J_m) < TOL

        z_e = bm.ee_pose(theta_z, qb, qm, fbs.com_position)
        assert rel_err(z_e[:2], fbs.ee_pose[:2]) < TOL
        assert abs(angle_diff(z_e[2], fbs.ee_pose[2])) < TOL

        # Eq. (4): Y_z theta_z + (0, 0, dq_e/dt) = J_b w_b + J_m w_m + (v_0, 0), which is the
        # end-effector's velocity that Pinocchio computes from the full state
        zdot = bm.Y_z(qb, qm, w) @ theta_z + np.array([0.0, 0.0, bm.ee_attitude_rate(w)])
        expected = fbs.J_b[:, 0] * w[0] + fbs.J_m @ w[1:]
        expected[:2] += fbs.com_velocity
        assert rel_err(zdot, expected) < TOL
        pin.forwardKinematics(robot.model, data, q, v)
        twist = pin.getFrameVelocity(
            robot.model, data, robot.ee_frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        assert rel_err(zdot, [twist.linear[0], twist.linear[1], twist.angular[2]]) < TOL


def check_layout(bm, n, collinear):
    nb = n + 1
    assert bm.layout.collinear is collinear
    n_z = 2 + nb if collinear else 2 + 2 * nb
    n_d = nb * (nb + 1) // 2 + (0 if collinear else n * nb // 2)
    assert (bm.n_z, bm.n_d, bm.n_b) == (n_z, n_d, n_d + 1)
    assert bm.true_theta_z([0.0, 0.0]).shape == (n_z,)
    assert bm.theta_d.shape == (n_d,)
    assert bm.true_theta_b(0.0).shape == (n_d + 1,)
    assert len(bm.layout.theta_d_names()) == n_d
    assert len(bm.layout.theta_z_names()) == n_z
    qb, qm, w = 0.1, np.linspace(-1, 1, n), np.linspace(0.5, -0.5, nb)
    assert bm.Y_z(qb, qm, w).shape == (3, n_z)
    for Y in (bm.Y_M(qb, qm, w), bm.Y_Mdot(qb, qm, w, w), bm.Y_h(qb, qm, w)):
        assert Y.shape == (nb, n_d)
    assert bm.Y_b(qb, qm, w).shape == (1, n_d + 1)


# ----------------------------------------------------------------------------- vs Pinocchio
@PROPERTY
@given(seed=SEEDS)
def test_paper_robot_matches_pinocchio(paper_robot, random_state, seed):
    check_against_pinocchio(paper_robot, seed, random_state)


@PROPERTY
@given(seed=SEEDS, n=N_LINKS)
def test_collinear_chains_match_pinocchio(make_chain, random_state, seed, n):
    robot = make_chain(n, offaxis=False, seed=seed)
    check_layout(BarycentricModel(robot.geometry), n, collinear=True)
    check_against_pinocchio(robot, seed, random_state)


@PROPERTY
@given(seed=SEEDS, n=N_LINKS)
def test_offaxis_chains_match_pinocchio(make_chain, random_state, seed, n):
    robot = make_chain(n, offaxis=True, seed=seed)
    check_layout(BarycentricModel(robot.geometry), n, collinear=False)
    check_against_pinocchio(robot, seed, random_state)


@settings(derandomize=True, max_examples=10, deadline=None)
@given(seed=SEEDS, n=N_LINKS)
def test_tilted_collinear_chains_match_pinocchio(
    random_chain, random_state, tmp_path_factory, seed, n
):
    """Collinear along lines that are not the body x axes: still the short layout."""
    chain = tilted(random_chain(n, seed=seed), np.random.default_rng(seed))
    robot = load_robot(write_urdf(chain, tmp_path_factory.mktemp("tilted") / "t.urdf"))
    bm = BarycentricModel(robot.geometry)
    check_layout(bm, n, collinear=True)
    assert np.abs(bm.direction_angles).max() > 0.01  # the lines really are tilted
    check_against_pinocchio(robot, seed, random_state)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_joint_and_end_effector_yaws(yawed_robots, random_state, seed):
    collinear, offaxis = yawed_robots
    np.testing.assert_allclose(collinear.geometry.joint_yaws, [0.3, 0, -0.8, 0, 0], atol=1e-15)
    assert offaxis.geometry.ee_yaw == pytest.approx(0.55, abs=1e-15)
    check_layout(BarycentricModel(collinear.geometry), 5, collinear=True)
    check_layout(BarycentricModel(offaxis.geometry), 5, collinear=False)
    for robot in yawed_robots:
        check_against_pinocchio(robot, seed, random_state)


@pytest.mark.parametrize("frame", ["link2", "joint4", "link1"])
def test_end_effector_on_inner_body(frame, random_state, data_dir):
    """Bodies beyond the end effector only enter through the CoM (E_k = 0 there)."""
    for urdf in ("ffsm_planar4.urdf", data_dir / "planar5_offaxis.urdf"):
        robot = load_robot(urdf, end_effector=frame)
        check_against_pinocchio(robot, 7, random_state)


@pytest.mark.parametrize("name", ["planar5_collinear", "planar5_offaxis"])
def test_test_robots_match_pinocchio(name, data_dir, random_state):
    robot = load_robot(data_dir / f"{name}.urdf")
    check_layout(BarycentricModel(robot.geometry), 5, collinear=name.endswith("collinear"))
    check_against_pinocchio(robot, 11, random_state, n_states=10)


# ----------------------------------------------------------------------------- layout
def test_paper_layout_sizes(paper_robot):
    bm = BarycentricModel(paper_robot.geometry)
    assert bm.layout.collinear
    assert (bm.n_z, bm.n_d, bm.n_b) == (7, 15, 16)  # Table 2's sizes
    check_layout(bm, 4, collinear=True)


def test_wrong_parameter_shapes_raise(paper_robot):
    bm = BarycentricModel(paper_robot.geometry)
    qm = np.zeros(4)
    with pytest.raises(ParameterError, match=r"theta_d.*\(15,\)"):
        bm.mass_matrix(np.zeros(14), 0.0, qm)
    with pytest.raises(ParameterError, match=r"theta_z.*\(7,\)"):
        bm.jacobians(np.zeros(8), 0.0, qm)
    with pytest.raises(ParameterError, match=r"theta_b.*\(16,\)"):
        bm.momentum_matrices(np.zeros(15), 0.0, qm)


# ----------------------------------------------------------------------------- regressors
def check_regressors(robot, seed):
    """Each regressor column against its defining product (docs/model.md section 3)."""
    bm = BarycentricModel(robot.geometry)
    rng = np.random.default_rng(seed)
    nb = robot.n_joints + 1
    qb = rng.uniform(-math.pi, math.pi)
    qm = rng.uniform(-math.pi, math.pi, nb - 1)
    w, a, s = rng.normal(size=(3, nb))
    x0 = np.concatenate(([qb], qm))

    def M(theta, x):
        return bm.mass_matrix(theta, x[0], x[1:])

    Y_M = bm.Y_M(qb, qm, a)
    Y_Mdot = bm.Y_Mdot(qb, qm, w, s)
    Y_h = bm.Y_h(qb, qm, w)
    for p in range(bm.n_d):
        e_p = np.zeros(bm.n_d)
        e_p[p] = 1.0
        # M(q) a is linear in theta: exact up to rounding
        assert rel_err(Y_M[:, p], M(e_p, x0) @ a) < 1e-13
        # dM/dt s along w
        Mdot = derivative(lambda t, e_p=e_p: M(e_p, x0 + t * w))
        assert rel_err(Y_Mdot[:, p], Mdot @ s) < FD_TOL
        # velocity product of the Lagrangian T_p = 1/2 w^T M(e_p) w: dM/dt w - dT_p/dq
        grad = np.array(
            [
                derivative(lambda t, i=i, e_p=e_p: 0.5 * w @ M(e_p, x0 + t * np.eye(nb)[i]) @ w)
                for i in range(nb)
            ]
        )
        assert rel_err(Y_h[:, p], Mdot @ w - grad) < FD_TOL

    theta = rng.normal(size=bm.n_d)  # any parameters, not only the true ones
    Mdot = derivative(lambda t: M(theta, x0 + t * w))
    assert rel_err(bm.mass_matrix_rate(theta, qb, qm, w), Mdot) < FD_TOL
    assert rel_err(bm.Y_d(qb, qm, w, a, s) @ theta, M(theta, x0) @ a - Mdot @ s + Y_h @ theta) < (
        FD_TOL
    )
    # M(q) does not depend on the base attitude
    assert rel_err(M(theta, x0 + np.eye(nb)[0] * 0.7), M(theta, x0)) < 1e-13

    # kinematics for any theta_z: J is the derivative of p_e - p_com, Y_z its regressor
    theta_z = rng.normal(size=bm.n_z)
    J_b, J_m = bm.jacobians(theta_z, qb, qm)
    J = np.hstack((J_b, J_m))
    for i in range(nb):
        dx = np.eye(nb)[i]

        def pose(t, dx=dx):
            x = x0 + t * dx
            return np.array([*bm.ee_offset(theta_z, x[0], x[1:]), bm.ee_angle(x[0], x[1:])])

        assert rel_err(J[:, i], derivative(pose)) < FD_TOL
    zdot = bm.Y_z(qb, qm, w) @ theta_z + np.array([0.0, 0.0, bm.ee_attitude_rate(w)])
    expected = J @ w
    expected[:2] += theta_z[:2]
    assert rel_err(zdot, expected) < 1e-13


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=SEEDS, n=N_LINKS, offaxis=st.booleans())
def test_regressor_columns_match_finite_differences(make_chain, seed, n, offaxis):
    check_regressors(make_chain(n, offaxis=offaxis, seed=seed), seed)


def test_paper_regressor_columns_match_finite_differences(paper_robot):
    check_regressors(paper_robot, 3)


def test_Yd_matches_pinocchio_mass_matrix_rate(paper_robot, data_dir, rng, random_state):
    """Y_d theta_d = M s1 - dM/dt s2 + C w with true theta_d, dM/dt by differentiating
    Pinocchio's reduced M along the motion (independent of the regressor code)."""
    for robot in (paper_robot, load_robot(data_dir / "planar5_offaxis.urdf")):
        bm = BarycentricModel(robot.geometry)
        fbs = FloatingBaseState(robot)
        q, v = random_state(robot, rng)
        nb = robot.n_joints + 1
        s1, s2 = rng.normal(size=(2, nb))

        def M_pin(t, q=q, v=v, fbs=fbs, model=robot.model):
            return fbs.update(pin.integrate(model, q, t * v), v).M.copy()

        Mdot = derivative(M_pin)
        fbs.update(q, v)
        qb, qm = split(q)
        expected = fbs.M @ s1 - Mdot @ s2 + fbs.h
        assert rel_err(bm.Y_d(qb, qm, fbs.w, s1, s2) @ bm.theta_d, expected) < FD_TOL


# ----------------------------------------------------------------------------- the paper
def test_paper_true_parameters_belong_to_three_link_chain(tmp_path):
    """The paper's listed true theta_z and theta_d (docs/model.md section 2) are those of the
    base + links 1-3 of Table 1, end effector at link 3's tip. Independent numbers: the paper's,
    rounded to 4 decimals (hence 5e-5 for theta_z; theta_d's larger entries get 5e-4)."""
    links = [(6.3, 1.0290), (5.4, 0.8820), (5.1, 0.8330)]
    chain = PlanarChain(
        name="paper_three_links",
        base=PlanarBody(mass=61.2, inertia=26.112),
        mount=(0.8, 0.0),
        links=tuple(
            PlanarLink(mass=m, inertia=i, com=(0.7, 0.0), tip=(1.4, 0.0)) for m, i in links
        ),
    )
    robot = load_robot(write_urdf(chain, tmp_path / "three.urdf"))
    assert robot.geometry.total_mass == pytest.approx(78.0, abs=1e-12)
    bm = BarycentricModel(robot.geometry)
    assert (bm.n_z, bm.n_d) == (6, 10)
    np.testing.assert_allclose(
        bm.true_theta_z([0.0988, 0.0943]),
        [0.0988, 0.0943, 0.6277, 1.1550, 1.2600, 1.3542],
        rtol=0,
        atol=5e-5,
    )
    names = bm.layout.theta_d_names()
    order = ["Dc00", "Dc11", "Dc22", "Dc33", "Dc01", "Dc12", "Dc13", "Dc02", "Dc23", "Dc03"]
    paper = [34.5482, 20.0140, 11.9952, 3.1686, 11.9952, 12.6126, 4.1234, 6.8544, 4.4982, 2.2409]
    np.testing.assert_allclose(
        [bm.theta_d[names.index(k)] for k in order], paper, rtol=0, atol=5e-4
    )


def test_returned_angles_do_not_alias_the_cache(paper_robot):
    bm = BarycentricModel(paper_robot.geometry)
    qm = np.array([0.1, 0.2, 0.3, 0.4])
    phi = bm.angles(0.5, qm)
    expected = phi.copy()
    M = bm.mass_matrix(bm.theta_d, 0.5, qm)
    try:
        phi[:] = 0.0  # a caller working in place on "its" array
    except ValueError:
        pass  # read-only arrays are a fine answer
    try:
        bm.body_angles(0.5, qm).c[:] = 1.0
    except ValueError:
        pass
    np.testing.assert_array_equal(bm.angles(0.5, qm), expected)
    np.testing.assert_array_equal(bm.mass_matrix(bm.theta_d, 0.5, qm), M)
