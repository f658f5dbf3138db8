"""The recorders' reused memory (ffsm_pin.sim.chunk_pool): an array is np.full's, its memory
comes back only when no view of it is left, and runs recorded on reused memory give the rows
of runs on fresh memory, bit for bit, while the earlier results stay intact."""

from __future__ import annotations

import dataclasses
import gc
import threading
import warnings

import numpy as np
import pytest

from ffsm_pin.scenario.devices import SensorSpec
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.chunk_pool import MIN_BYTES, ChunkPool
from ffsm_pin.sim.lockstep import simulate_lockstep
from ffsm_pin.sim.run import prepare, simulate
from ffsm_pin.sweep.worker import recorder_pool


def test_an_array_is_np_full_and_its_memory_returns_with_its_last_view():
    pool = ChunkPool(min_bytes=0)
    a = pool.full((40, 7), np.nan)
    assert a.shape == (40, 7) and a.dtype == np.float64 and a.flags.c_contiguous
    assert a.flags.writeable and np.isnan(a).all()
    a[:] = 1.0
    view = a[3:5, 2:]  # a recorded signal's slice, held by a result
    del a
    gc.collect()
    assert pool.free_bytes == 0  # the view still reads the memory: nothing comes back
    b = pool.full((40, 7), np.nan)
    assert pool.reused == 0 and np.isnan(b).all()  # a new chunk, not the view's
    assert np.all(view == 1.0)
    del view
    gc.collect()
    assert pool.free_bytes == 40 * 7 * 8
    c = pool.full((280,), 2.5)  # the same size, another shape: the kept chunk, filled anew
    assert pool.reused == 1 and np.all(c == 2.5)
    b[:] = 0.0
    assert np.all(c == 2.5)  # (b's memory is another chunk)


def test_other_sizes_release_the_kept_chunks_and_small_arrays_bypass_the_pool():
    pool = ChunkPool(min_bytes=800)
    small = pool.full((99,), np.nan)  # 792 bytes: np.full's own
    assert pool.handed_out == 0 and np.isnan(small).all()
    a = pool.full((100,), np.nan)
    del a
    gc.collect()
    assert pool.free_bytes == 800
    b = pool.full((200,), np.nan)  # another size: what was kept is released first
    assert pool.free_bytes == 0 and pool.reused == 0
    del b
    gc.collect()
    assert pool.free_bytes == 1600
    pool.clear()
    assert pool.free_bytes == 0
    assert ChunkPool().min_bytes == MIN_BYTES
    assert pool.full((0, 3)).shape == (0, 3)


def test_chunks_given_back_from_other_threads():
    pool = ChunkPool(min_bytes=0)
    arrays = [pool.full((64,), np.nan) for _ in range(8)]

    def drop():
        while arrays:
            arrays.pop()

    thread = threading.Thread(target=drop)
    thread.start()
    thread.join()
    gc.collect()
    assert pool.free_bytes == 8 * 64 * 8
    again = [pool.full((64,), np.nan) for _ in range(8)]
    assert pool.reused == 8 and all(np.isnan(x).all() for x in again)


def _scenarios(count: int) -> list:
    sc = builtin_scenario("case1")
    out = []
    for i in range(count):
        est = dataclasses.replace(sc.controller.estimates, initial="perturbed", seed=10 + i)
        ctrl = dataclasses.replace(sc.controller, estimates=est)
        sensors = SensorSpec(seed=20 + i, noise=(("joints", 1e-4),))
        out.append(dataclasses.replace(sc, duration=0.3, controller=ctrl, sensors=sensors))
    return out


def _signals(result) -> dict[str, np.ndarray]:
    return {k: np.array(v, copy=True) for k, v in result.signals.items()}


def _assert_equal(held: dict[str, np.ndarray], result) -> None:
    assert sorted(held) == sorted(result.signals)
    for key, value in held.items():
        assert np.array_equal(value, np.asarray(result.signals[key]), equal_nan=True), key


@pytest.mark.parametrize("lockstep", [False, True])
def test_runs_on_reused_memory_equal_runs_on_fresh_memory(lockstep):
    """Every array of the recorders from the pool (min_bytes 0); the first runs' results are
    still held while the next ones run, the pool must not hand out their memory, and a third
    round after they are dropped reuses it: all equal to the runs without a pool."""

    def run(pool):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setups = [prepare(sc) for sc in _scenarios(2)]
            if lockstep:
                return simulate_lockstep(setups, pool=pool)
            return [simulate(s, pool=pool) for s in setups]

    fresh = [_signals(r) for r in run(None)]
    pool = ChunkPool(min_bytes=0)
    first = run(pool)
    second = run(pool)  # while the first results are held
    for held, a, b in zip(fresh, first, second, strict=True):
        _assert_equal(held, a)  # not overwritten by the second round
        _assert_equal(held, b)
    del first, second, a, b
    gc.collect()
    third = run(pool)
    assert pool.reused > 0
    for held, c in zip(fresh, third, strict=True):
        _assert_equal(held, c)


def test_a_worker_has_one_pool():
    assert recorder_pool() is recorder_pool()
    assert isinstance(recorder_pool(), ChunkPool)
