"""The first compilation of the compiled period on two processes (control/_first_compile.py,
``period.compile_in_parallel`` for either geometry): the argument types
survive the trip to the second process, a warm cache starts no process, and a run from an
empty numba cache (kernels compiled in two processes) gives bitwise the trajectory of a run
from a warm cache, planar and spatial."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof

from ffsm_pin.control import _first_compile, period
from ffsm_pin.model.planar import PlanarKernelConstants
from ffsm_pin.model.spatial import SpatialKernelConstants
from ffsm_pin.sim.compile_note import MESSAGE

REPO = Path(__file__).resolve().parents[2]


def test_array_types_survive_the_trip_to_the_second_process():
    """numba types a read-only array differently from a writeable one, and pickling drops
    the flag: the second process must see the types this one passes."""
    ro = np.arange(6.0)
    ro.setflags(write=False)
    view = np.zeros((4, 5))[:, 2:]  # non-contiguous: layout 'A'
    args = (ro, np.ones(3), (7, True, ro), view)
    back = _first_compile.restore_flags(pickle.loads(pickle.dumps(_first_compile.with_flags(args))))
    assert typeof(back[0]) == typeof(ro) and not back[0].flags.writeable
    assert typeof(back[1]) == typeof(args[1]) and back[1].flags.writeable
    assert back[2][:2] == (7, True) and typeof(back[2][2]) == typeof(ro)
    np.testing.assert_array_equal(back[3], view)  # values kept (layout becomes 'C')
    # a named tuple (the models' kernel constants) keeps its class, which numba types it by
    geo = PlanarKernelConstants(ro, np.ones(2), np.zeros(1, dtype=np.int64), None, 3.0, True)
    geo_back = _first_compile.restore_flags(
        pickle.loads(pickle.dumps(_first_compile.with_flags(geo)))
    )
    assert type(geo_back) is PlanarKernelConstants and typeof(geo_back) == typeof(geo)


@pytest.mark.parametrize(
    "geo", [PlanarKernelConstants, SpatialKernelConstants], ids=["planar", "spatial"]
)
def test_a_warm_cache_starts_no_second_process(monkeypatch, geo):
    started = []
    monkeypatch.setattr(_first_compile, "cold", lambda dispatcher: False)
    monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: started.append(a))
    period.compile_in_parallel(geo(*([None] * len(geo._fields))), *([None] * 4))
    assert started == []


def test_the_second_process_imports_this_copy_of_the_package(monkeypatch, tmp_path):
    """``python -c`` puts its working folder first on sys.path: run from a checkout's root
    with the package installed (``ffsm-sim``), the second process would compile the checkout's
    kernels, into another cache."""
    started = []

    class Stop(Exception):
        pass

    def popen(cmd, **kwargs):
        started.append(cmd)
        raise Stop

    with monkeypatch.context() as patch, pytest.raises(Stop):
        patch.setattr(_first_compile, "cold", lambda dispatcher: True)
        patch.setattr(subprocess, "Popen", popen)
        _first_compile.compile_in_parallel("m", (), [object()], lambda: None)
    decoy = tmp_path / "ffsm_pin"
    decoy.mkdir()
    (decoy / "__init__.py").write_text("raise SystemExit('the decoy was imported')\n")
    code = started[0][-1].replace(
        "_child_main as f; f()", "_child_main; print(sys.modules['ffsm_pin'].__file__)"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, check=True)  # fmt: skip
    assert (
        Path(out.stdout.strip())
        == Path(_first_compile.__file__).resolve().parents[1] / "__init__.py"
    )


def test_the_period_goes_on_when_its_kernels_are_ready_and_the_run_waits_for_the_rest(
    monkeypatch, tmp_path
):
    """The protocol with a stand-in kernel module: ``compile_in_parallel`` returns once the
    second process has done ``_compile_real_kernels`` (the period's kernels), while it still
    does ``_compile_run_kernels``; :func:`_first_compile.finish` waits for that."""
    (tmp_path / "standin_kernels.py").write_text(
        "import pathlib, time\n"
        "def _compile_real_kernels(folder):\n"
        "    pathlib.Path(folder, 'period').touch()\n"
        "def _compile_run_kernels(folder):\n"
        "    time.sleep(2.0)\n"
        "    pathlib.Path(folder, 'run').touch()\n"
    )
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    monkeypatch.setattr(_first_compile, "cold", lambda dispatcher: True)
    monkeypatch.setattr(_first_compile, "ALSO", [])
    # only this test's second process: one an earlier test of this worker started (a
    # prepare() on a cold cache, on a fresh machine) is not this protocol's to count
    monkeypatch.setattr(_first_compile, "_PENDING", [])
    here = []
    _first_compile.compile_in_parallel(
        "standin_kernels", (str(tmp_path),), [object()], lambda: here.append(1)
    )
    assert here == [1]  # this process's share ran meanwhile
    assert (tmp_path / "period").exists()  # returned after the period's kernels ...
    assert not (tmp_path / "run").exists()  # ... while the run's were still compiling
    assert len(_first_compile._PENDING) == 1
    _first_compile.finish()
    assert (tmp_path / "run").exists() and _first_compile._PENDING == []


@pytest.mark.slow
@pytest.mark.parametrize(
    ("case", "second_process_kernel"),
    [("case1", "velocity_regressors"), ("spatial", "velocity_terms")],
    ids=["planar", "spatial"],
)
def test_a_run_from_an_empty_cache_equals_a_run_from_a_warm_one(
    tmp_path, case, second_process_kernel
):
    """20-70 s: everything compiled anew, the complex kinematic law here and the real
    kernels in the second process. Also the per-user cache (``ffsm_pin/_numba_cache.py``) and
    the compile line (``ffsm_pin/sim/compile_note.py``): the line appears on the cold run
    only, and a run from another folder finds the same cache (one cache per installation)."""
    xdg = tmp_path / "xdg"

    def run(out: str) -> tuple[dict, str]:
        env = {**os.environ, "XDG_CACHE_HOME": str(xdg), "PYTHONPATH": str(REPO)}
        env.pop("NUMBA_CACHE_DIR", None)  # the package picks $XDG_CACHE_HOME/ffsm-pin/numba
        (tmp_path / out).mkdir()
        proc = subprocess.run(
            [sys.executable, "-m", "ffsm_pin.sim", "--case", case, "--duration", "0.2",
             "--no-plots", "--no-html", "--out", "run"],
            cwd=tmp_path / out, env=env, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        return dict(np.load(tmp_path / out / "run" / "trajectory.npz")), proc.stderr

    cache = xdg / "ffsm-pin" / "numba"
    first, cold_err = run("cold")
    assert MESSAGE in cold_err  # a fresh cache: compilation really happens, and is announced
    # the second process's kernels are cached
    assert any(cache.rglob(f"*{second_process_kernel}*.nbi"))
    # <cache>/<kernel digest>/<module path>: ffsm_pin/_numba_cache.py's locator
    assert any(cache.glob("*/control/period/*.nbi"))
    # the built-in cases run without the null-space term: its gradient is not compiled
    # (null_space_term gives None, which numba's branch pruning sees)
    assert not any(cache.rglob("*_null_space_gradient*.nbi"))
    second, warm_err = run("warm")  # another folder, the same cache
    assert MESSAGE not in warm_err
    assert first.keys() == second.keys()
    for key in first:
        np.testing.assert_array_equal(first[key], second[key], err_msg=key)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["case1", "spatial"], ids=["planar", "spatial"])
def test_the_second_process_runs_without_error(case, monkeypatch, tmp_path):
    """What the second process runs (the geometry module's ``_compile_real_kernels``, with the
    arguments a real controller passes, through the pickle, then the plant's kernels) exits 0
    and prints nothing, and a run's plant then loads its kernels from the cache it wrote: a
    broken second process only makes a first run slower, which the run test above cannot
    see (the period and the plant compile whatever is missing themselves)."""
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.run import prepare

    captured = {}

    def capture(module, child_args, dispatchers, compile_here):
        captured["payload"] = (module, child_args)

    monkeypatch.setattr(_first_compile, "compile_in_parallel", capture)
    monkeypatch.setattr(_first_compile, "cold", lambda dispatcher: True)
    prepare(dataclasses.replace(builtin_scenario(case), duration=0.01))
    module, child_args = captured["payload"]
    assert module == "ffsm_pin.control.period"  # one period; the geometry from the constants
    geometry = PlanarKernelConstants if case == "case1" else SpatialKernelConstants
    assert type(child_args[0]) is geometry  # (the model's constants, the law's, ...)
    assert "ffsm_pin.sim.plant" in _first_compile.ALSO  # registered by the plant's module
    env = {**os.environ, "PYTHONPATH": str(REPO), "NUMBA_CACHE_DIR": str(tmp_path)}
    proc = subprocess.run(
        [sys.executable, "-c", "from ffsm_pin.control._first_compile import _child_main as f; f()"],
        input=pickle.dumps((module, _first_compile.with_flags(child_args), _first_compile.ALSO)),
        capture_output=True, env=env, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr.decode()[-3000:]
    assert proc.stdout == _first_compile.READY and proc.stderr == b""
    # a run's plant, on the real robot, finds every kernel it calls in that cache
    probe = (
        "import numpy as np\n"
        "from ffsm_pin.robot import load_robot\n"
        "from ffsm_pin.scenario import builtin_scenario\n"
        "from ffsm_pin.sim import plant as P\n"
        "from ffsm_pin.sim.initial import initial_state\n"
        f"sc = builtin_scenario({case!r}); r = sc.robot\n"
        "opts = {'satellite': r.satellite, 'locked_joints': dict(r.locked_joints) or None}\n"
        "opts = opts if r.base == 'free-flyer' else {}\n"
        "robot = load_robot(r.urdf, r.end_effector, base=r.base, **opts)\n"
        "q, v = initial_state(robot, sc.initial)\n"
        "plant = P.Plant(robot)\n"
        "plant.reset(q, v); plant.project(q, v)\n"
        "plant.advance(q, v, np.zeros(robot.n_joints), 1e-3)\n"
        "print(sum(len(k.stats.cache_misses) for k in (P._project_base, P._euler_velocity)),\n"
        "      sum(len(k.stats.cache_hits) for k in (P._project_base, P._euler_velocity)))\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env,
                         timeout=600, check=True)  # fmt: skip
    misses, hits = map(int, out.stdout.split())
    assert (misses, hits) == (0, 2), out.stdout
