"""The spatial barycentric model (docs/spatial.md sections 2-4) against Pinocchio
(SpatialState: CRBA, RNEA, centroidal map, frame Jacobians) on random chains, and every
regressor column against finite differences of its defining quantity.

Property tests run with hypothesis, derandomized (the same examples on every run)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffsm_pin.attitude import mrp
from ffsm_pin.model.interface import ReducedModel
from ffsm_pin.model.planar import BarycentricModel
from ffsm_pin.model.spatial import SpatialBarycentricModel
from ffsm_pin.model.state import State as SpatialState

PROPERTY = settings(derandomize=True, max_examples=15, deadline=None)
SEEDS = st.integers(0, 10_000)
N_LINKS = st.integers(2, 8)
TOL = 1e-10  # relative to the largest entry (entries are O(1)-O(100))
FD_TOL = 1e-8  # 5-point stencil at h = 1e-3: truncation ~ h^4, rounding ~ 1e-16/h


def rel(a, b, floor=1.0):
    return float(np.abs(np.asarray(a) - b).max() / max(np.abs(b).max(), floor))


def derivative(f, h=1e-3):
    return (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)


def _setup(spatial_chain, spatial_state, seed, n):
    robot = spatial_chain(n, seed % 3)
    rng = np.random.default_rng(seed)
    q, v = spatial_state(robot, rng)
    s = SpatialState(robot).update(q, v)
    return robot, SpatialBarycentricModel(robot.geometry), s, rng


@PROPERTY
@given(seed=SEEDS, n=N_LINKS)
def test_model_equals_pinocchio(spatial_chain, spatial_state, seed, n):
    robot, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    th = bm.theta_d
    assert rel(bm.mass_matrix(th, qb, qm), s.M) < TOL
    a = rng.normal(size=n + 3)
    assert rel(bm.Y_M(qb, qm, a) @ th, s.M @ a) < TOL
    assert rel(bm.velocity_product(th, qb, qm, w), s.h) < TOL
    assert rel(bm.Y_h(qb, qm, w) @ th, s.h) < TOL
    assert rel(bm.Y_T(qb, qm, w) @ th, 0.5 * w @ s.M @ w) < TOL
    assert rel(bm.mass_matrix_rate(th, qb, qm, w)[:3, :3], s.M_bb_dot) < TOL
    tb = bm.true_theta_b(s.angular_momentum)
    H_bb, H_bm, A0 = bm.momentum_matrices(tb, qb, qm)
    assert rel(H_bb, s.H_bb) < TOL and rel(H_bm, s.H_bm) < TOL
    assert rel(bm.Y_b(qb, qm, w) @ tb, np.zeros(3), floor=np.abs(A0).max()) < TOL  # Eq. (14)
    tz = bm.true_theta_z(s.com_velocity)
    J_b, J_m = bm.jacobians(tz, qb, qm)
    assert rel(J_b, s.J_b) < TOL and rel(J_m, s.J_m) < TOL
    assert rel(bm.ee_pose(tz, qb, qm, s.com_position), s.ee_pose) < TOL
    # Eq. (4): J_b w_b + J_m w_m + v_0 = Y_z theta_z + (0, dq_e/dt)
    lhs = J_b @ w[:3] + J_m @ w[3:] + np.concatenate((s.com_velocity, np.zeros(3)))
    rhs = bm.Y_z(qb, qm, w) @ tz + np.concatenate((np.zeros(3), bm.ee_attitude_rate(w, qb, qm)))
    assert rel(rhs, lhs) < TOL
    # reaction torque (Eq. 7) from the model and from Pinocchio's quantities
    w_dot = rng.normal(size=n + 3)
    assert rel(bm.reaction_torque(th, qb, qm, w, w_dot), s.reaction_torque(w_dot)) < TOL


@PROPERTY
@given(seed=SEEDS, n=N_LINKS)
def test_Y_d_against_aba(spatial_chain, spatial_state, seed, n):
    """Y_d theta_d = M s1 - dM/dt s2 + C w with s1 = dw/dt from ABA and s2 = 0 gives (0, u)."""
    robot, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    u = rng.normal(scale=10.0, size=n)
    a = pin.aba(robot.model, robot.model.createData(), s.q, s.v, np.concatenate((np.zeros(6), u)))
    w_dot = s.acceleration_to_w_dot(a)
    Yd = bm.Y_d(s.base_attitude, s.joint_angles, s.w, w_dot, np.zeros(n + 3))
    scale = max(np.abs(s.M).max() * np.abs(w_dot).max(), np.abs(u).max())
    assert np.abs(Yd @ bm.theta_d - np.concatenate((np.zeros(3), u))).max() < 1e-11 * scale


def _path(robot, s):
    """Base MRP and joint angles along q(t) = integrate(q, v t) (w constant along it)."""

    def at(t):
        q = pin.integrate(robot.model, s.q, s.v * t)
        return mrp.from_quaternion(q[3:7]), q[7:]

    return at


@pytest.mark.parametrize("n", [2, 4])
def test_regressor_columns_against_finite_differences(spatial_chain, spatial_state, rng, n):
    """Every column at once: the columns of Y_M(q, s) are M(e_c) s, so d/dt Y_M(q(t), s) is
    Y_Mdot(w, s); Y_h = d/dt Y_M(q(t), w) - (0, d/dq_m Y_T(q, w)) (docs/spatial.md section 4);
    the V_k columns of Y_z are d/dt R_k(t)."""
    robot = spatial_chain(n, 1)
    q, v = spatial_state(robot, rng)
    s = SpatialState(robot).update(q, v)
    bm = SpatialBarycentricModel(robot.geometry)
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    at = _path(robot, s)
    sv = rng.normal(size=n + 3)

    fd_Mdot = derivative(lambda t: bm.Y_M(*at(t), sv))
    assert rel(bm.Y_Mdot(qb, qm, w, sv), fd_Mdot) < FD_TOL
    fd_Yw = derivative(lambda t: bm.Y_M(*at(t), w))
    dT = np.array(
        [derivative(lambda e, j=j: bm.Y_T(qb, qm + e * np.eye(n)[j], w)) for j in range(n)]
    )
    expected = fd_Yw.copy()
    expected[3:] -= dT
    assert rel(bm.Y_h(qb, qm, w), expected) < FD_TOL
    Y_Mdot2, Y_h2 = bm.velocity_regressors(qb, qm, w, sv)
    assert rel(Y_Mdot2, fd_Mdot) < FD_TOL and rel(Y_h2, expected) < FD_TOL

    fd_R = derivative(lambda t: np.swapaxes(bm.kinematics(*at(t)).R, 0, 1).reshape(3, -1))
    Yz = bm.Y_z(qb, qm, w)
    assert rel(Yz[:3, 3:], fd_R) < FD_TOL
    assert np.all(Yz[3:] == 0.0) and np.all(Yz[:3, :3] == np.eye(3))

    fd_A = derivative(lambda t: bm.mass_matrix(bm.theta_d, *at(t)))
    assert rel(bm.mass_matrix_rate(bm.theta_d, qb, qm, w), fd_A) < FD_TOL

    # Y_b columns: -E_3 for A_0, the first rows of Y_M(w) for theta_d (linearity in theta_b)
    Yb = bm.Y_b(qb, qm, w)
    for c in rng.choice(bm.n_b - 3, 10, replace=False):
        e = np.zeros(bm.n_b)
        e[3 + c] = 1.0
        H_bb, H_bm, _ = bm.momentum_matrices(e, qb, qm)
        assert rel(Yb[:, 3 + c], H_bb @ w[:3] + H_bm @ w[3:]) < 1e-14


def test_energy_identity(spatial_chain, spatial_state, rng):
    """w^T Y_M(q, w) = 2 Y_T(q, w) (T = 1/2 w^T M w), column by column."""
    robot = spatial_chain(5)
    s = SpatialState(robot).update(*spatial_state(robot, rng))
    bm = SpatialBarycentricModel(robot.geometry)
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    assert rel(w @ bm.Y_M(qb, qm, w), 2 * bm.Y_T(qb, qm, w)) < 1e-13


def test_sizes_and_names(spatial_chain):
    robot = spatial_chain(7)
    bm = SpatialBarycentricModel(robot.geometry)
    assert (bm.n_z, bm.n_d, bm.n_b) == (3 + 24, 6 * 8 + 9 * 28, 3 + 6 * 8 + 9 * 28)
    assert bm.n_d == 300  # docs/spatial.md: 300 for a 7-joint arm
    assert len(bm.layout.theta_d_names()) == bm.n_d
    assert len(bm.layout.theta_z_names()) == bm.n_z
    assert (bm.m2, bm.m3) == (3, 3)


def test_shared_interface(spatial_chain, paper_robot):
    """Planar and spatial models satisfy the same protocol (the controller is written once)."""
    spatial = SpatialBarycentricModel(spatial_chain(3).geometry)
    planar = BarycentricModel(paper_robot.geometry)
    assert isinstance(spatial, ReducedModel) and isinstance(planar, ReducedModel)
    assert (planar.m2, planar.m3) == (2, 1)


def test_bad_parameter_shapes(spatial_chain):
    from ffsm_pin.errors import ParameterError

    bm = SpatialBarycentricModel(spatial_chain(3).geometry)
    with pytest.raises(ParameterError, match="theta_d"):
        bm.mass_matrix(np.zeros(5), np.zeros(3), np.zeros(3))


@PROPERTY
@given(seed=SEEDS, n=st.integers(1, 8))
def test_compiled_kernels_equal_numpy_reference(spatial_chain, spatial_state, seed, n):
    """The numba backend (default) reproduces the vectorised numpy reference, method by method;
    the two share no code below the method level (loops over pairs vs einsum)."""
    robot = spatial_chain(n, seed % 3)
    rng = np.random.default_rng(seed)
    s = SpatialState(robot).update(*spatial_state(robot, rng))
    fast = SpatialBarycentricModel(robot.geometry)
    ref = SpatialBarycentricModel(robot.geometry, backend="numpy")
    assert fast.backend == "numba" and ref.backend == "numpy"
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    a, sv = rng.normal(size=n + 3), rng.normal(size=n + 3)
    th = fast.theta_d * rng.uniform(0.5, 1.5, fast.n_d)  # any parameter vector, not the truth
    tz = fast.true_theta_z(s.com_velocity)
    pairs = [
        (fast.mass_matrix(th, qb, qm), ref.mass_matrix(th, qb, qm)),
        (fast.Y_M(qb, qm, a), ref.Y_M(qb, qm, a)),
        (fast.Y_b(qb, qm, w), ref.Y_b(qb, qm, w)),
        (fast.Y_z(qb, qm, w), ref.Y_z(qb, qm, w)),
        (np.hstack(fast.jacobians(tz, qb, qm)), np.hstack(ref.jacobians(tz, qb, qm))),
        (fast.Y_Mdot(qb, qm, w, sv), ref.Y_Mdot(qb, qm, w, sv)),
        (fast.Y_h(qb, qm, w), ref.Y_h(qb, qm, w)),
        (np.hstack(fast.velocity_regressors(qb, qm, w, sv)),
         np.hstack(ref.velocity_regressors(qb, qm, w, sv))),
        (fast.Y_d(qb, qm, w, a, sv), ref.Y_d(qb, qm, w, a, sv)),
    ]  # fmt: skip
    for got, expected in pairs:
        assert rel(got, expected) < 1e-12
    # the fused call returns the separate methods' values
    fused = fast.controller_terms(tz, th, qb, qm, w, a, sv)
    separate = ref.controller_terms(tz, th, qb, qm, w, a, sv)
    for name, got, expected in zip(fused._fields, fused, separate, strict=True):
        assert got.shape == expected.shape, name
        assert rel(got, expected) < 1e-12, name


@pytest.mark.parametrize("n", [1, 4, 7])
def test_velocity_terms_without_some_regressors_keeps_the_others_bits(
    spatial_chain, spatial_state, rng, n
):
    """``velocity_terms`` with Y_M, Y_Mdot or Y_h None (what the paper's controller, gjm-ct
    and adaptive-ct do not use) writes the other outputs with the bits of the full call, and
    never reads the vector of a regressor it skips (NaN there would show)."""
    from ffsm_pin.model._spatial_kinematics_kernels import kinematics
    from ffsm_pin.model._spatial_velocity_kernels import velocity_terms

    robot = spatial_chain(n, n % 3)
    s = SpatialState(robot).update(*spatial_state(robot, rng))
    bm = SpatialBarycentricModel(robot.geometry)
    consts = bm.kernel_constants()
    N, nd = n + 3, bm.n_d
    R, z = np.empty((n + 1, 3, 3)), np.empty((n, 3))
    kinematics(s.base_attitude, s.joint_angles, consts.joint_rot, consts.axes, R, z)
    w, a, sv = s.w, rng.normal(size=N), rng.normal(size=N)
    full = [np.empty((N, nd)) for _ in range(3)] + [np.empty((3, nd))]
    velocity_terms(R, z, w, a, sv, *full)
    nan = np.full(N, np.nan)
    skips = [(True, False, False), (False, True, False), (True, True, False),
             (True, False, True), (False, False, True)]  # fmt: skip
    for skip_ym, skip_ymdot, skip_yh in skips:
        out = [np.full((N, nd), np.nan) for _ in range(3)] + [np.full((3, nd), np.nan)]
        velocity_terms(
            R, z, w, nan if skip_ym else a, nan if skip_ymdot else sv,
            None if skip_ym else out[0], None if skip_ymdot else out[1],
            None if skip_yh else out[2], out[3],
        )  # fmt: skip
        skipped = (skip_ym, skip_ymdot, skip_yh, False)
        kept = [i for i, skip in enumerate(skipped) if not skip]
        for i in kept:
            assert np.array_equal(out[i], full[i]), (skipped, i)


@pytest.mark.parametrize("n", [1, 4, 7])
def test_dynamic_level_regressor_is_one_velocity_regressor(spatial_chain, spatial_state, rng, n):
    """What the compiled spatial period forms for Eqs. (49)-(52) (docs/spatial.md section 4):
    Y_c = Y_Mdot(w, w-hat) less the dT/dq rows equals -(Y_Mdot(w, w~) - Y_h(w)) of the numpy
    reference (w~ = w - w-hat), and Y_M(a) added into it in place (``add_ym``) equals the
    reference's Y_M(a) + Y_c: the filter input of Eq. (50)."""
    from ffsm_pin.model._spatial_kinematics_kernels import kinematics
    from ffsm_pin.model._spatial_mass_kernels import add_ym, ym
    from ffsm_pin.model._spatial_velocity_kernels import subtract_dT, velocity_terms

    robot = spatial_chain(n, n % 3)
    s = SpatialState(robot).update(*spatial_state(robot, rng))
    bm = SpatialBarycentricModel(robot.geometry)
    ref = SpatialBarycentricModel(robot.geometry, backend="numpy")
    consts = bm.kernel_constants()
    N, nd = n + 3, bm.n_d
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    R, z = np.empty((n + 1, 3, 3)), np.empty((n, 3))
    kinematics(qb, qm, consts.joint_rot, consts.axes, R, z)
    w_hat = w + 0.3 * rng.normal(size=N) * np.abs(w).max()
    a = rng.normal(size=N)
    Yc, Yb = np.full((N, nd), np.nan), np.empty((3, nd))
    velocity_terms(R, z, w, w, w_hat, None, Yc, None, Yb)
    subtract_dT(R, z, w, Yc)
    expected = ref.Y_Mdot(qb, qm, w, w - w_hat) - ref.Y_h(qb, qm, w)
    assert rel(Yc, -expected) < 1e-12
    Y_dc = Yc.copy()
    add_ym(R, z, a, Y_dc, False)
    assert rel(Y_dc, ref.Y_M(qb, qm, a) - expected) < 1e-12
    # ym is add_ym into zeros, bit for bit
    Y0, Y1 = np.full((N, nd), np.nan), np.zeros((N, nd))
    ym(R, z, a, Y0, False)
    add_ym(R, z, a, Y1, False)
    assert np.array_equal(Y0, Y1)


def test_unknown_backend(spatial_chain):
    from ffsm_pin.errors import ParameterError

    with pytest.raises(ParameterError, match="'numba', 'numpy'"):
        SpatialBarycentricModel(spatial_chain(2).geometry, backend="jax")


def test_complex_step_through_the_kinematics(spatial_chain, spatial_state, rng):
    """The numpy path accepts complex configurations (the controller differentiates its
    kinematic law by a complex step): Im f(x + i h dx) / h equals central differences of the
    real evaluations, for the Jacobians (attitude rows included), the ee pose and M."""
    robot = spatial_chain(5, 2)
    s = SpatialState(robot).update(*spatial_state(robot, rng))
    bm = SpatialBarycentricModel(robot.geometry)
    qb, qm = s.base_attitude, s.joint_angles
    dqb, dqm = rng.normal(size=3), rng.normal(size=5)
    tz = bm.true_theta_z(s.com_velocity)
    h = 1e-30

    def f(qb_, qm_):
        J_b, J_m = bm.jacobians(tz, qb_, qm_)
        pose = bm.ee_pose(tz, qb_, qm_, np.zeros(3))
        return np.concatenate(
            (J_b.ravel(), J_m.ravel(), pose, bm.mass_matrix(bm.theta_d, qb_, qm_).ravel())
        )

    cs = f(qb + 1j * h * dqb, qm + 1j * h * dqm).imag / h
    fd = derivative(lambda e: f(qb + e * dqb, qm + e * dqm))
    assert rel(cs, fd) < FD_TOL


@pytest.mark.parametrize(
    ("name", "ee", "locks"),
    [("panda", "panda_hand", {"panda_finger_joint1": 0.03, "panda_finger_joint2": 0.01}),
     ("ur5", "ee_link", {})],
)  # fmt: skip
def test_example_robot_data_arms_on_a_satellite(spatial_state, rng, name, ee, locks):
    """A real arm (fixed links merged, fingers locked off-centre, world link at the root) on a
    satellite: the barycentric model equals Pinocchio."""
    from ffsm_pin.robot import load_spatial_robot

    robot = load_spatial_robot(
        f"example-robot-data:{name}",
        ee,
        locked_joints=locks,
        satellite={"mass": 300.0, "inertia": (50, 40, 30, 1, 0, 0), "mount_rpy": (0.1, 0, 0)},
    )
    bm = SpatialBarycentricModel(robot.geometry)
    for _ in range(3):
        s = SpatialState(robot).update(*spatial_state(robot, rng))
        qb, qm, w = s.base_attitude, s.joint_angles, s.w
        terms = bm.controller_terms(bm.true_theta_z(s.com_velocity), bm.theta_d, qb, qm, w, w, w)
        assert rel(terms.M, s.M) < TOL
        assert rel(terms.Y_h @ bm.theta_d, s.h) < TOL
        assert rel(terms.J_b, s.J_b) < TOL and rel(terms.J_m, s.J_m) < TOL
        assert rel(terms.Y_b @ bm.true_theta_b(s.angular_momentum), np.zeros(3), 10.0) < TOL


@PROPERTY
@given(seed=SEEDS, n=st.integers(1, 8))
def test_reference_mass_matrix_complex_step_is_the_exact_rate(
    spatial_chain, spatial_state, seed, n
):
    """The numpy reference's M at complex arguments x + i h dx (what the tangent kernels are
    checked against below): its real part is M, its imaginary part over h the exact rate,
    the parameters' direction plus dM/dt along the motion, i.e. M(theta') + the columns
    Y_Mdot(w, e_j) theta."""
    _, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    th = bm.theta_d * rng.uniform(0.5, 1.5, bm.n_d)
    dth = rng.normal(size=bm.n_d)
    h = 1e-30
    got = bm.mass_matrix(th + 1j * h * dth, qb + 1j * h * (mrp.L_matrix(qb) @ w[:3]),
                         qm + 1j * h * w[3:])  # fmt: skip
    rate = bm.mass_matrix(dth, qb, qm) + np.column_stack(
        [bm.Y_Mdot(qb, qm, w, e) @ th for e in np.eye(n + 3)]
    )
    assert rel(got.real, bm.mass_matrix(th, qb, qm)) < 1e-14
    assert rel(got.imag / h, rate) < 1e-12


def _rotations(bm, s):
    """(R, z) of the compiled kernels at the state ``s``: body rotations and joint axes."""
    from ffsm_pin.model._spatial_kinematics_kernels import kinematics

    n = len(s.joint_angles)
    R, z = np.empty((n + 1, 3, 3)), np.empty((n, 3))
    kinematics(s.base_attitude, s.joint_angles, bm._joint_rot_c, bm._axes_c, R, z)
    return R, z


@PROPERTY
@given(seed=SEEDS, n=st.integers(1, 8))
def test_mass_times_kernel_is_the_mass_matrix_product(spatial_chain, spatial_state, seed, n):
    """``mass_times`` (M a without forming M, the diagnostic e of Eq. 54) equals Pinocchio's M
    times a, and the numpy reference's product with any parameters, to rounding."""
    from ffsm_pin.model._spatial_mass_kernels import mass_times

    robot, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    R, z = _rotations(bm, s)
    a = rng.normal(size=n + 3)
    out = np.empty(n + 3)
    mass_times(R, z, bm.theta_d, a, out)
    assert rel(out, s.M @ a) < TOL
    th = bm.theta_d * rng.uniform(0.5, 1.5, bm.n_d)  # any parameters, not only a body's
    ref = SpatialBarycentricModel(robot.geometry, backend="numpy")
    M = ref.mass_matrix(th, s.base_attitude, s.joint_angles)
    mass_times(R, z, th, a, out)
    assert rel(out, M @ a) < 1e-14


@PROPERTY
@given(seed=SEEDS, n=st.integers(1, 8))
def test_base_inertia_rate_is_the_complex_step_of_the_reference(
    spatial_chain, spatial_state, seed, n
):
    """``base_inertia_rate``: M_bb, and dM_bb/dt in real arithmetic, equal to the numpy
    reference's M_bb and its exact complex step along the motion (dq_b/dt = L_b w_b,
    dq_m/dt = w_m), to rounding."""
    from ffsm_pin.model._spatial_mass_tangent_kernels import base_inertia_rate

    robot, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    ref = SpatialBarycentricModel(robot.geometry, backend="numpy")
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    th = bm.theta_d * rng.uniform(0.5, 1.5, bm.n_d)
    R, z = _rotations(bm, s)
    M, M_dot = np.empty((3, 3)), np.empty((3, 3))
    base_inertia_rate(R, z, w, th, M, M_dot)
    h = 1e-30
    want = ref.mass_matrix(th + 0j, qb + 1j * h * (mrp.L_matrix(qb) @ w[:3]),
                           qm + 1j * h * w[3:])[:3, :3]  # fmt: skip
    assert rel(M, want.real) < 1e-14
    assert rel(M_dot, want.imag / h, 1e-300) < 1e-13


@PROPERTY
@given(seed=SEEDS, n=st.integers(1, 8))
def test_base_columns_kernel_is_the_complex_reference(spatial_chain, spatial_state, seed, n):
    """``base_columns`` (the kinematic law's H_bb, H_bm at a complex step, in real (value,
    tangent) arithmetic) gives the numpy reference's base columns of M at the same complex
    arguments: the values to rounding and the imaginary parts (the exact rate along the motion
    and the parameters' direction) to rounding of their own size; with a zero step, zero
    imaginary parts."""
    from ffsm_pin.model._spatial_kinematics_kernels import kinematics
    from ffsm_pin.model._spatial_mass_tangent_kernels import base_columns

    robot, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    ref = SpatialBarycentricModel(robot.geometry, backend="numpy")
    qb, qm, w = s.base_attitude, s.joint_angles, s.w
    th = bm.theta_d * rng.uniform(0.5, 1.5, bm.n_d)
    dth = rng.normal(size=bm.n_d) * np.abs(th).max()
    h = 1e-30
    for step in (h, 0.0):
        qb_c, qm_c = qb + 1j * step * (mrp.L_matrix(qb) @ w[:3]), qm + 1j * step * w[3:]
        Rc, zc = np.empty((n + 1, 3, 3), complex), np.empty((n, 3), complex)
        kinematics(qb_c, qm_c, bm._joint_rot_c, bm._axes_c, Rc, zc)
        got = np.empty((n + 3, 3), complex)
        base_columns(Rc, zc, th + 1j * step * dth, got)
        want = ref.mass_matrix(th + 1j * step * dth, qb_c, qm_c)[:, :3]
        assert rel(got.real, want.real) < 1e-14
        if step:
            assert rel(got.imag / h, want.imag / h, 1e-300) < 1e-13
        else:
            assert not np.any(got.imag)


@PROPERTY
@given(seed=SEEDS, n=st.integers(1, 8))
def test_mass_matrix_by_sums_is_the_mass_matrix(spatial_chain, spatial_state, seed, n):
    """``mass_matrix_by_sums`` (the one compiled M: the periods' M-hat, the model's M) is
    Pinocchio's M with the true parameters and the numpy reference's M with any parameters, to
    rounding; symmetric bit for bit."""
    from ffsm_pin.model._spatial_mass_kernels import mass_matrix_by_sums

    robot, bm, s, rng = _setup(spatial_chain, spatial_state, seed, n)
    ref = SpatialBarycentricModel(robot.geometry, backend="numpy")
    R, z = _rotations(bm, s)
    got = np.empty((n + 3, n + 3))
    mass_matrix_by_sums(R, z, bm.theta_d, got)
    assert rel(got, s.M) < TOL
    th = bm.theta_d * rng.uniform(0.5, 1.5, bm.n_d) + rng.normal(size=bm.n_d)
    mass_matrix_by_sums(R, z, th, got)
    assert rel(got, ref.mass_matrix(th, s.base_attitude, s.joint_angles)) < 1e-14
    assert np.array_equal(got, got.T)
