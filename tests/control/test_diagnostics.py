"""The true-model quantities the run records: the reaction torque of control/diagnostics.py
(compiled kernels equal to the numpy reference, which equals the model's reaction_torque,
itself checked against Pinocchio in tests/model), and e of Eq. (54), which the paper's control
period reports (compiled and numpy, equal to its definition at the states before the period)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ffsm_pin.control import fast, fast_spatial
from ffsm_pin.control.controller import SingularityWarning
from ffsm_pin.control.diagnostics import reaction_torques
from ffsm_pin.control.interface import SignalRow
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.errors import SimulationError
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.measurement import Sensor
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.run import prepare


def _compiled_base_inertia(model, theta_d):
    """The kernels' f(q_b, q_m, w) -> (M_bb, dM_bb/dt) of the true model."""
    if model.m3 == 3:
        jr, ax = model.kernel_constants()[:2]
        return lambda q_b, q_m, w: fast_spatial.base_inertia(jr, ax, q_b, q_m, w, theta_d)
    k = model.kernel_constants()
    geo = (k.S, k.phi_offset, k.K, k.L, k.collinear)
    return lambda q_b, q_m, w: fast.base_inertia(*geo, q_b, q_m, w, theta_d)


def _reference_base_inertia(model, theta_d, q_b, q_m, w):
    """(M_bb, dM_bb/dt) from the numpy model: M's base block, and the columns of the
    symmetric dM/dt as its regressor times theta_d, one base direction each."""
    m3 = model.m3
    M = model.mass_matrix(theta_d, q_b, q_m)
    basis = np.eye(model.n_joints + m3)[:m3]
    Mbb_dot = np.column_stack([model.Y_Mdot(q_b, q_m, w, e)[:m3] @ theta_d for e in basis])
    if m3 == 1:
        return M[0, 0], Mbb_dot[0, 0]
    return M[:m3, :m3], Mbb_dot


def _recorded_rows(model, rng, rows: int) -> tuple:
    """Random recorded rows as a run stores them: q_b (N, m3), q_m, w, dw/dt (N, n + m3) and
    dw_b, the base's part of dw/dt, (N,) planar or (N, 3) spatial."""
    m3, nb, n = model.m3, model.n_joints + model.m3, model.n_joints
    q_b = rng.uniform(-3, 3, (rows, 1)) if m3 == 1 else rng.uniform(-0.4, 0.4, (rows, 3))
    q_m = rng.uniform(-2, 2, (rows, n))
    w = rng.normal(size=(rows, nb))
    w_dot = rng.normal(size=(rows, nb))
    return q_b, q_m, w, w_dot, (w_dot[:, 0] if m3 == 1 else w_dot[:, :3])


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_compiled_base_inertia_equals_reference_and_reaction_torque(geometry, reduced_model_of):
    model = reduced_model_of(geometry)
    m3, nb = model.m3, model.n_joints + model.m3
    theta_d = np.array(model.theta_d)
    rng = np.random.default_rng(4)
    compiled_base_inertia = _compiled_base_inertia(model, theta_d)
    for _ in range(4):
        q_b = rng.uniform(-3, 3) if m3 == 1 else rng.uniform(-0.4, 0.4, 3)
        q_m = rng.uniform(-2, 2, model.n_joints)
        w, w_dot = rng.normal(size=(2, nb))
        M = model.mass_matrix(theta_d, q_b, q_m)
        Mbb, Mbb_dot = _reference_base_inertia(model, theta_d, q_b, q_m, w)
        Mbb_f, Mbb_dot_f = compiled_base_inertia(q_b, q_m, w)
        np.testing.assert_allclose(Mbb_f, Mbb, rtol=1e-12)
        np.testing.assert_allclose(Mbb_dot_f, Mbb_dot, rtol=1e-9, atol=1e-9 * np.max(np.abs(M)))
        np.testing.assert_allclose(np.atleast_2d(Mbb), np.atleast_2d(M[:m3, :m3]), rtol=1e-14)
        # the reaction torque of Eq. (7) from these terms, as the after-run pass forms it
        F_r = model.reaction_torque(theta_d, q_b, q_m, w, w_dot)
        if m3 == 1:
            mine = Mbb_f * w_dot[0] + 0.5 * Mbb_dot_f * w[0]
        else:
            from ffsm_pin.model._state_spatial import reaction_torque

            mine = reaction_torque(Mbb_f, Mbb_dot_f, w[:3], w_dot[:3])
        np.testing.assert_allclose(mine, F_r, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("urdf", ["paper", "planar5_collinear.urdf", "planar5_offaxis.urdf"])
def test_planar_base_inertia_equals_the_whole_products(urdf, data_dir):
    """The planar kernel forms M_bb and dM_bb/dt from the base entries alone; they equal the
    base entries of the whole products it once formed, S^T M_phi S and Y_Mdot(w, e_0) theta_d
    (compiled here as they were): dM_bb/dt bit for bit (the same BLAS call on the same
    matrix), M_bb to the rounding of its sum (the loop adds the terms in ascending order, a
    BLAS in its own; on the development machine the bits agree too). Both layouts (collinear,
    off-axis) and a joint turning about -z (planar5: link 3)."""
    from numba import njit

    from ffsm_pin.model import make_model
    from ffsm_pin.model._planar_kernels import mass_phi, trig, velocity_regressors
    from ffsm_pin.robot import load_robot

    @njit
    def whole(S, off, K, L, collinear, q_b, q_m, w, theta_d):
        nb = S.shape[0]
        c, s, pc, ps = trig(S, off, K, L, q_b, q_m)
        Mphi = mass_phi(theta_d, pc, ps, K, L, nb, collinear)
        M = S.T @ Mphi @ S
        e0 = np.zeros(nb)
        e0[0] = 1.0
        Ymd, _ = velocity_regressors(pc, ps, K, L, S, w, e0, theta_d.size, collinear)
        return M[0, 0], (Ymd @ theta_d)[0], np.abs(S.T) @ np.abs(Mphi) @ np.abs(S)

    model = make_model(load_robot("ffsm_planar4.urdf" if urdf == "paper" else data_dir / urdf))
    k = model.kernel_constants()
    geo = (k.S, k.phi_offset, k.K, k.L, k.collinear)
    theta_d = np.array(model.theta_d)
    rng = np.random.default_rng(11)
    exact = 0
    for _ in range(200):
        q_b, q_m = rng.uniform(-3, 3), rng.uniform(-3, 3, model.n_joints)
        w = rng.normal(0, 2, model.n_joints + 1)
        M_bb, M_bb_dot = fast.base_inertia(*geo, q_b, q_m, w, theta_d)
        M_whole, M_dot_whole, size = whole(*geo, q_b, q_m, w, theta_d)
        assert M_bb_dot == M_dot_whole
        # the sum's rounding: one ulp of each of its nb^2 partial sums, of at most sum |terms|
        nb = len(q_m) + 1
        assert abs(M_bb - M_whole) <= nb**2 * np.finfo(float).eps * size[0, 0]
        exact += M_bb == M_whole
    print(f"M_bb bit for bit in {exact} of 200")  # (pytest -s)


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_reaction_torques_after_the_run_equal_the_model_row_by_row(geometry, reduced_model_of):
    """F_r computed after a run on a block of recorded rows (one compiled pass, and the numpy
    reference) equals the model's reaction_torque (Eq. 7) row by row; the planar pass is also
    bitwise the per-row formula the run loop used (the spatial one was checked bitwise on the
    built-in cases with tools/compare_runs.py, its matrix products are BLAS calls)."""
    model = reduced_model_of(geometry)
    m3 = model.m3
    theta_d = np.array(model.theta_d)
    rows = 5
    q_b, q_m, w, w_dot, dw_b = _recorded_rows(model, np.random.default_rng(7), rows)
    fast, ref = (reaction_torques(model, theta_d, c)(q_b, q_m, w, dw_b) for c in (True, False))
    assert fast.shape == ref.shape == ((rows,) if m3 == 1 else (rows, 3))
    per_row = _compiled_base_inertia(model, theta_d)
    for i in range(rows):
        qb = q_b[i, 0] if m3 == 1 else q_b[i]
        F_r = model.reaction_torque(theta_d, qb, q_m[i], w[i], w_dot[i])
        np.testing.assert_allclose(fast[i], F_r, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(ref[i], F_r, rtol=1e-9, atol=1e-9)
        Mbb, Mbb_dot = per_row(qb, q_m[i], w[i])
        if m3 == 1:
            np.testing.assert_array_equal(fast[i], Mbb * dw_b[i] + 0.5 * Mbb_dot * w[i, 0])


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
@pytest.mark.parametrize("rows", [0, 1, 7])
def test_rows_beside_other_work_equal_one_pass(geometry, rows, reduced_model_of, monkeypatch):
    """After a run, F_r's pass is cut into pieces that a second thread and this one take in
    turn while this one computes the rest (rows_beside): the rows are independent, so the
    result is bitwise the single pass's, for every cut (pieces of 2 rows, odd counts, no row),
    and the other work's result comes back unchanged."""
    from ffsm_pin.control import diagnostics
    from ffsm_pin.control.diagnostics import rows_beside

    model = reduced_model_of(geometry)
    theta_d = np.array(model.theta_d)
    q_b, q_m, w, _, dw_b = _recorded_rows(model, np.random.default_rng(3), rows)
    f = reaction_torques(model, theta_d, True)
    one_pass = f(q_b, q_m, w, dw_b)
    assert len(one_pass) == rows
    for piece in (2, 3, 256):
        monkeypatch.setattr(diagnostics, "ROWS_PER_PIECE", piece)
        calls: list[int] = []

        def rest(calls=calls) -> str:
            calls.append(1)
            return "rest"

        result, other = rows_beside(f, (q_b, q_m, w, dw_b), rest)
        np.testing.assert_array_equal(result, one_pass)
        assert result.shape == one_pass.shape
        assert other == "rest" and calls == [1]


def test_rows_beside_stops_the_second_thread_when_the_other_work_fails(monkeypatch):
    """An error in the other work (or Ctrl-C) reaches the caller, and the second thread takes
    no piece after it: a slow kernel over many pieces is not waited for to the end."""
    import threading
    import time

    from ffsm_pin.control import diagnostics
    from ffsm_pin.control.diagnostics import rows_beside

    monkeypatch.setattr(diagnostics, "ROWS_PER_PIECE", 1)
    pieces: list[int] = []
    first_piece = threading.Event()

    def slow_kernel(x):
        pieces.append(len(x))
        first_piece.set()
        time.sleep(0.02)
        return x

    def failing() -> None:
        first_piece.wait(5)
        raise KeyboardInterrupt

    rows = (np.arange(1000.0),)
    with pytest.raises(KeyboardInterrupt):
        rows_beside(slow_kernel, rows, failing)
    # pieces halve (500, 250, ...): without the stop the second thread would go on to the end
    assert sum(pieces) < len(rows[0])

    def kernel_fails(x):
        raise ValueError("bad row")

    with pytest.raises(ValueError, match="bad row"):
        rows_beside(kernel_fails, rows, lambda: None)


class _ClosedLoop:
    """The plant of ``setup`` from its initial state, measured exactly at each period's start
    (:meth:`measure`) and advanced over the period by the torque a controller gave."""

    def __init__(self, setup, full_model: bool):
        self.sensor = Sensor(setup.robot, setup.model, full_model=full_model)
        self.plant = Plant(setup.robot)
        self.q, self.v = setup.q0.copy(), setup.v0.copy()
        self.plant.reset(self.q, self.v)
        self.dt, self.k = setup.scenario.dt, 0

    def measure(self):
        return self.sensor.measure(self.k * self.dt, self.q, self.v)

    def advance(self, u_m) -> None:
        self.q, self.v, _ = self.plant.step(self.q, self.v, u_m, self.dt)
        self.k += 1


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_the_period_reports_e_of_eq_54_by_its_definition(case, backend):
    """The paper's controller reports e = M w~ + Y_df (theta_d - theta_d-hat) of Eq. (54) with
    the true M and theta_d, which its period computes at the measured state: it equals the
    definition evaluated by the numpy model on the states *before* the period (w-hat, Y_df,
    theta_d-hat), along 40 closed-loop periods in which Y_df and theta_d-hat move. The numpy
    reference is that expression, bit for bit; the compiled period forms M by its own kernel,
    within rounding. w~ = w - w-hat is reported bit for bit by both."""
    setup = prepare(builtin_scenario(case))
    ctrl, model, theta_d = setup.controller, setup.model, setup.theta_d
    law = ctrl.law
    assert law.backend == "numba"
    law.backend = backend
    loop = _ClosedLoop(setup, full_model=False)
    for k in range(40):
        meas = loop.measure()
        w_hat, Y_df, theta_hat = law.w_hat.copy(), law.Y_df.copy(), law.theta_d.copy()
        u_m, signals = ctrl.step(meas)
        w_tilde = meas.w - w_hat
        M = model.mass_matrix(theta_d, meas.q_b, meas.q_m)
        e = M @ w_tilde + Y_df @ (theta_d - theta_hat)
        np.testing.assert_array_equal(signals["w_tilde"], w_tilde)
        if backend == "numpy":
            np.testing.assert_array_equal(signals["e"], e)
        else:  # the kernel's M: rounding of sums over a few terms of size |M| |w~|
            scale = np.abs(M).max() * np.abs(w_tilde).max() + np.abs(Y_df @ theta_d).max()
            np.testing.assert_allclose(signals["e"], e, rtol=0, atol=1e-13 * scale)
        if k > 1:
            assert np.abs(Y_df @ (theta_d - theta_hat)).max() > 1e-9  # the term is exercised
        loop.advance(u_m)
    assert not np.array_equal(law.theta_d, setup.theta_d)  # the estimates moved


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("case", ["known-model", "spatial-known-model"])
def test_the_known_model_reports_e_and_w_tilde_zero(case, backend):
    """Known model: w~ = 0, Y_df = 0 and theta_d-hat = theta_d, so e = 0 (+0.0, as recorded
    before e came from the period)."""
    setup = prepare(builtin_scenario(case))
    ctrl = setup.controller
    law = ctrl.law
    if backend == "numba" and law.backend == "numpy":  # the planar default: ask for numba
        ctrl = LuJiaController(ctrl.context, backend="numba")
        law = ctrl.law
    law.backend = backend
    sensor = Sensor(setup.robot, setup.model, full_model=True)
    meas = sensor.measure(0.0, setup.q0, setup.v0)
    _, signals = ctrl.step(meas)
    for key in ("e", "w_tilde"):
        assert signals[key].shape == (setup.model.n_joints + setup.model.m3,)
        assert np.all(signals[key] == 0) and not np.any(np.signbit(signals[key]))


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("case", ["case1", "spatial", "known-model"])
def test_the_period_reports_its_signals_as_one_row_of_its_layout(case, backend):
    """``ControlOutput.signals`` is the row of the controller's ``signal_layout``: the
    estimates and w-hat at t, bit for bit the copies taken *before* the period (which
    advances them in place on the compiled backend), w~ = w - w-hat bit for bit, and w_mc,
    sigma_min and the damping the law's named outputs (on the numpy backend separate arrays;
    compiled, views of the same buffer, whose values against the numpy reference
    test_fast*.py check); the paper's controller returns that row (a SignalRow), along 30
    closed-loop periods. e's slot: the Eq. (54) test above, which reads it from this row."""
    setup = prepare(builtin_scenario(case))
    ctrl = setup.controller
    law = ctrl.law
    if backend == "numba" and law.backend == "numpy":  # the planar known-model default
        ctrl = LuJiaController(ctrl.context, backend="numba")
        law = ctrl.law
    law.backend = backend
    layout = law.signal_layout
    assert ctrl.signal_layout is layout and ctrl.signal_shapes == dict(layout.shapes)
    loop = _ClosedLoop(setup, full_model=not law.adaptive)
    for k in range(30):
        meas = loop.measure()
        before = {
            "theta_z_hat": law.theta_z.copy(), "theta_d_hat": law.theta_d.copy(),
            "theta_b_hat": law.theta_b.copy(), "w_hat": law.w_hat.copy(),
        }  # fmt: skip
        if k % 2:  # through the controller: the reply carries the row itself
            u_m, signals = ctrl.step(meas)
            assert isinstance(signals, SignalRow) and signals.layout is layout
            row = signals.row
        else:  # the law's output: the row beside the named outputs it repeats
            out = law.step(meas, loop.dt)
            u_m, row = out.u_m, out.signals
            assert row is not None and row.shape == (layout.size,)
            named = {"w_tilde": out.w_tilde, "e": out.e, "w_mc": out.w_mc,
                     "sigma_min": out.sigma_min, "damping": out.damping}  # fmt: skip
            for key, value in named.items():
                assert np.array_equal(row[layout.index(key)], value), key
        for key, value in before.items():
            assert np.array_equal(row[layout.index(key)], value), key
        w_tilde = meas.w - before["w_hat"] if law.adaptive else np.zeros_like(meas.w)
        assert np.array_equal(row[layout.index("w_tilde")], w_tilde)
        loop.advance(u_m)
    if law.adaptive:
        assert not np.array_equal(law.theta_d, setup.theta_d)  # the estimates moved


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("case", ["case1", "case2", "spatial"])
def test_step_row_runs_the_same_period_as_step(case, backend):
    """:meth:`CoordinatedController.step_row` (what the paper's controller calls) is the
    period of :meth:`~CoordinatedController.step` without the other named outputs: two
    controllers built alike, fed the same measurements of one closed loop, give the same
    u_m and signals' row bit for bit and keep the same estimates, through the periods where
    damped least squares is active (case 2 enters them at about 1.34 s; both book them as
    an event), and at a funnel exit (case 1 and spatial; case 2 enforces no
    funnel), which both raise with the same message."""
    setup = prepare(builtin_scenario(case))
    other = prepare(builtin_scenario(case))
    by_step, by_row = setup.controller.law, other.controller.law
    by_step.backend = by_row.backend = backend
    loop = _ClosedLoop(setup, full_model=False)
    periods = 1500 if case == "case2" else 30
    damped = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SingularityWarning)
        for _ in range(periods):
            meas = loop.measure()
            out, row = by_step.step(meas, loop.dt), by_row.step_row(meas, loop.dt)
            assert np.array_equal(out.u_m, row.u_m)
            assert np.array_equal(out.signals, row.signals)
            damped += out.damping > 0
            loop.advance(out.u_m)
        for name in ("theta_z", "theta_d", "theta_b", "w_hat"):
            assert np.array_equal(getattr(by_step, name), getattr(by_row, name)), name
        assert by_step.damped_since == by_row.damped_since
        assert (damped > 0) == (case == "case2")
        # the bookkeeping saw the damped periods (its event), not only the shared path
        for law in (by_step, by_row):
            assert any("near a singularity" in e for e in law.events) == (damped > 0)
    if case == "case2":
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SingularityWarning)
        outside = loop.measure()._replace(z_e=loop.measure().z_e + 100.0)  # far outside
        stops = []
        for call in (lambda: by_step.step(outside, loop.dt),
                     lambda: by_row.step_row(outside, loop.dt)):  # fmt: skip
            with pytest.raises(SimulationError) as caught:
                call()
            stops.append(str(caught.value))
    assert stops[0] == stops[1] and "funnel" in stops[0]
