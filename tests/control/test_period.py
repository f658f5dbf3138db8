"""The one compiled control period (control/period.py): each geometry's steps are registered,
the outputs' signals are views of one row of the layout, and a step the period compiled is
callable from Python (the period and the geometry's own dispatcher share cache entries, so they
must compile the same code). The period's values against the numpy reference:
tests/control/test_fast.py and test_fast_spatial.py."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.control import period
from ffsm_pin.control.interface import SignalLayout
from ffsm_pin.model.planar import PlanarKernelConstants
from ffsm_pin.model.spatial import SpatialKernelConstants

REPO = Path(__file__).resolve().parents[2]
STEPS = ("geometry_terms", "kinematic_law", "dynamic_level")


@pytest.mark.parametrize("cls", [PlanarKernelConstants, SpatialKernelConstants])
def test_each_geometry_provides_the_three_steps_as_cached_kernels(cls):
    """The period compiles each step as the kernel's own Python function with the options the
    period names (_JIT_OPTIONS): they must be the kernel's own, since the two share cache
    entries (a kernel decorated otherwise would fail here)."""
    kernels = period.GEOMETRIES[cls]
    options = period._JIT_OPTIONS
    for name in STEPS:
        kernel = getattr(kernels, name)
        assert kernel.targetoptions.get("nopython", False) is options["nopython"], name
        wrapper = kernel.targetoptions.get("no_cpython_wrapper", False)
        assert wrapper is options["no_cpython_wrapper"], name
        cached = kernel._cache.__class__.__name__ == "FunctionCache"  # cache=True
        assert cached is options["cache"], name


@pytest.mark.parametrize(("m3", "n_task"), [(1, 3), (3, 6), (3, 3)])
@pytest.mark.parametrize("n", [2, 7])
def test_the_outputs_signals_are_views_of_one_row_of_the_layout(n, m3, n_task):
    """Each signal the period writes by name lands in its slot of the row the run records in
    one copy (the signals side by side in the layout's order, whatever that order), and the
    other outputs are arrays of their own."""
    N, n_z, n_d, n_b = n + m3, 5, 11, 4
    signals = {"w_tilde": (N,), "e": (N,), "theta_z_hat": (n_z,), "theta_d_hat": (n_d,),
               "theta_b_hat": (n_b,), "w_hat": (N,), "w_mc": (n,), "sigma_min": (),
               "damping": ()}  # fmt: skip
    for order in (list(signals), list(reversed(signals))):
        layout = SignalLayout({k: signals[k] for k in order})
        out, row = period.period_outputs(layout, n, m3, n_task)
        assert row.shape == (layout.size,)
        for key in period.SIGNALS:
            view = getattr(out, key)
            view[:] = np.arange(view.size) + 1.0 + 100 * period.SIGNALS.index(key)
            assert np.shares_memory(view, row), key
        for key in period.SIGNALS:  # each written exactly where the layout reads it
            want = np.arange(int(np.prod(signals[key]))) + 1.0 + 100 * period.SIGNALS.index(key)
            np.testing.assert_array_equal(np.atleast_1d(row[layout.index(key)]), want)
        sizes = {"u_m": n, "w_mc_dot": n, "err_b": m3, "err_z": n_task}
        for key, size in sizes.items():
            assert getattr(out, key).shape == (size,) and not np.shares_memory(
                getattr(out, key), row
            )
    with pytest.raises(ValueError, match="signals must be"):
        period.period_outputs(SignalLayout({"w_tilde": (N,)}), n, m3, n_task)


@pytest.mark.slow
def test_a_step_the_period_compiled_is_callable_from_python(tmp_path):
    """First process: the period compiles the geometry's steps itself (no second process), so
    the cache entries of the three kernels are written through the period. Second process,
    same cache: the kernels called from Python with the same argument types load those
    entries and run. With numba's default options for an overload (no CPython wrapper) the
    entry has no entry point for Python and the second process crashes."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "NUMBA_CACHE_DIR": str(tmp_path)}
    head = (
        "import dataclasses, importlib\n"
        "from ffsm_pin.control import _first_compile as F, fast\n"
        "from ffsm_pin.scenario import builtin_scenario\n"
        "from ffsm_pin.sim.setup import prepare\n"
    )
    first = head + (
        "F.compile_in_parallel = lambda *args: None\n"
        "prepare(dataclasses.replace(builtin_scenario('case1'), duration=0.01))\n"
    )
    second = head + (
        "def from_python(module, child_args, dispatchers, compile_here):\n"
        "    compile_here()  # the kinematic law, from Python\n"
        "    importlib.import_module(module)._compile_real_kernels(*child_args)  # the others\n"
        "F.compile_in_parallel = from_python\n"
        "F.cold = lambda dispatcher: True\n"
        "prepare(dataclasses.replace(builtin_scenario('case1'), duration=0.01))\n"
        "print(*(len(getattr(fast, k).stats.cache_hits) for k in "
        "('geometry_terms', 'kinematic_law', 'dynamic_level')))\n"
    )
    for script in (first, second):
        proc = subprocess.run(
            [sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=900
        )
        assert proc.returncode == 0, (proc.returncode, proc.stderr[-3000:])
    hits = [int(x) for x in proc.stdout.split()]
    assert hits == [1, 1, 1], hits  # each loaded the entry the period wrote


def _stepped(case: str):
    """(controller, its first measurement, dt) of the built-in ``case`` after one period at
    that measurement (its kernels loaded, its bundles and box made)."""
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.measurement import Sensor
    from ffsm_pin.sim.setup import prepare

    setup = prepare(dataclasses.replace(builtin_scenario(case), duration=0.01))
    controller = setup.controller
    sensor = Sensor(setup.robot, setup.model, full_model=controller.needs_dynamics)
    meas = sensor.measure(0.0, setup.q0.copy(), setup.v0.copy())
    controller.step(meas)
    return controller, meas, setup.scenario.dt


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_the_period_arguments_are_those_the_controller_steps_with(case):
    """``period(*law.period_arguments(meas, dt))`` is the controller's next period: from a
    copy of the state the torque and the advanced estimates are those the controller's own
    step gives at the same measurement, bit for bit (what benchmarks/bench_period_parts.py
    relies on); and the state in the arguments is the controller's live one."""
    from ffsm_pin.control.interface import split_reply

    controller, meas0, dt = _stepped(case)
    meas1 = meas0._replace(t=dt)
    args = controller.law.period_arguments(meas1, dt)
    assert all(a is b for a, b in zip(args.state, controller.law.state, strict=True))
    state = tuple(x.copy() for x in args.state)
    status = period.period(*args._replace(state=state))[0]
    assert status == period.STATUS_OK
    u_m = args.out[0].copy()  # PeriodOutputs.u_m
    u_step, _ = split_reply(controller.step(meas1))
    np.testing.assert_array_equal(u_m, u_step)
    for copied, live in zip(state, controller.law.state, strict=True):
        np.testing.assert_array_equal(copied, live)


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_the_period_box_follows_a_replaced_state(case):
    """The controller keeps the period's fixed arguments in one box (control/_period_box.py)
    and makes it again when its state is replaced (a capture joining a held body, a warm-up on
    copies, a setter such as ``theta_d = ...``): the next period advances the new arrays and
    leaves those of the state it no longer holds as they were."""
    controller, meas0, dt = _stepped(case)  # the box made, holding the live state
    law = controller.law
    old = law.state
    before = tuple(x.copy() for x in old)
    law.state = type(old)(*(x.copy() for x in old))  # a new state of equal values
    controller.step(meas0._replace(t=dt))
    for kept, now in zip(before, old, strict=True):  # the replaced state: untouched
        np.testing.assert_array_equal(kept, now)
    moved = [not np.array_equal(a, b) for a, b in zip(before, law.state, strict=True)]
    assert moved[3], moved  # the new state's w-hat advanced (Eq. 46)


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_a_copy_of_a_stepped_controller_goes_on_as_the_original(case):
    """``copy.deepcopy`` of a controller that has run periods (and so holds the period's box,
    which numba cannot copy) gives a controller that continues bit for bit as the original,
    torque and signals, on its own arrays: the original is not advanced by the copy's
    periods."""
    import copy

    from ffsm_pin.control.interface import split_reply

    controller, meas, dt = _stepped(case)
    twin = copy.deepcopy(controller)
    before = tuple(x.copy() for x in controller.law.state)
    for k in (1, 2):
        u_twin, row_twin = split_reply(twin.step(meas._replace(t=k * dt)))
    for kept, now in zip(before, controller.law.state, strict=True):
        np.testing.assert_array_equal(kept, now)  # the copy's periods left the original alone
    for k in (1, 2):
        u_orig, row_orig = split_reply(controller.step(meas._replace(t=k * dt)))
    np.testing.assert_array_equal(u_orig, u_twin)
    np.testing.assert_array_equal(row_orig.row, row_twin.row)  # the signals too
    for a, b in zip(controller.law.state, twin.law.state, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_the_period_called_through_its_handles_is_the_controllers_step(case):
    """A runner that calls the compiled period itself (``period_handles``, then ``settle``
    when the period is not plain; benchmarks/bench_lockstep.py) gets the torque and the
    signals' row the controller's own ``step`` gives, bit for bit, period after period; and a
    period whose status is a funnel exit is settled into the stop ``step`` raises."""
    import copy

    from ffsm_pin.control.interface import split_reply
    from ffsm_pin.errors import SimulationError

    controller, meas, dt = _stepped(case)
    twin = copy.deepcopy(controller)
    handles = twin.law.period_handles()
    for k in (1, 2, 3):
        m = meas._replace(t=k * dt)
        u_step, row = split_reply(controller.step(m))
        fields = (m.t, m.q_b, m.q_m, m.w, m.z_e, m.z_e_dot, handles.M, handles.h)
        status, idx, value = period.period_of(handles.box, dt, fields, handles.aux)
        assert status == period.STATUS_OK
        if handles.outputs.damping[0] != 0.0 or twin.law.damped_since is not None:
            twin.law.settle(m, status, idx, value)
        np.testing.assert_array_equal(handles.outputs.u_m, u_step)
        np.testing.assert_array_equal(handles.row, row.row)
    far = meas._replace(t=4 * dt, z_e=meas.z_e + 1.0)  # 1 m off: outside every funnel
    with pytest.raises(SimulationError) as by_step:
        controller.step(far)
    fields = (far.t, far.q_b, far.q_m, far.w, far.z_e, far.z_e_dot, handles.M, handles.h)
    status, idx, value = period.period_of(handles.box, dt, fields, handles.aux)
    assert status == period.STATUS_FUNNEL_Z
    with pytest.raises(SimulationError) as by_settle:
        twin.law.settle(far, status, idx, value)
    assert str(by_settle.value) == str(by_step.value)
