"""Saturation-aware prescribed performance (``controller.saturation = "auxiliary"``, issue 39):
the auxiliary system relaxes the funnels while the actuators saturate, keeps the command
bounded, and the prescribed funnel returns after the saturation; without saturation it is the
paper's law bit for bit; its numpy reference and compiled period agree (docs/saturation.md)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from ffsm_pin.control.saturation import (
    AuxiliarySystem,
    Saturation,
    auxiliary_term,
    demand_problem,
)
from ffsm_pin.errors import FfsmError, ParameterError
from ffsm_pin.scenario.devices import ActuatorSpec
from ffsm_pin.scenario.file import builtin_path, builtin_scenario, scenario_from_toml
from ffsm_pin.sim.relaxation import RELAXED_FRACTION, relaxation_summary
from ffsm_pin.sim.run import prepare, simulate

#: (built-in case, a constant torque limit [N m] that the paper's law exceeds at the start,
#: duration [s]); planar and spatial.
CASES = {"planar": ("case1", 3.0, 8.0), "spatial": ("spatial", 0.05, 8.0)}


def _scenario(name, mode, limit, duration, **rates):
    sc = builtin_scenario(name)
    law = dataclasses.replace(sc.controller.lu_jia, saturation=Saturation(mode, **rates))
    sc = dataclasses.replace(
        sc, controller=dataclasses.replace(sc.controller, lu_jia=law), duration=duration
    )
    if limit is not None:
        sc = dataclasses.replace(sc, actuators=ActuatorSpec(torque_limit=limit))
    return sc


def _run(sc):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(prepare(sc))


@pytest.mark.parametrize("geometry", CASES)
def test_a_saturating_law_relaxes_its_funnels_and_returns_to_them(geometry):
    """The issue's check. With a constant torque limit the paper's law exceeds (from t = 0),
    the auxiliary system (fast rates, so that the return fits the run) is exactly zero until
    the first excess and relaxes the funnels after it; the command never exceeds the law's
    first one or twice the limit, whereas the law that ignores the limit winds up well
    beyond it; the
    saturation ends, chi decays, the errors end inside the prescribed funnels, and the summary
    reports the relaxed stretch as the recorded chi shows it."""
    name, limit, duration = CASES[geometry]
    aux = _run(_scenario(name, "auxiliary", limit, duration, k_chi=1.0, k_v=2.0))
    ignore = _run(_scenario(name, "ignore", limit, duration))
    assert aux.completed
    u_c = np.asarray(aux["u_cmd"])
    chi = np.hstack((aux["ctrl_chi_b"], aux["ctrl_chi_z"]))
    sat = np.any(np.abs(u_c) > limit, axis=1)
    first, last = int(np.argmax(sat)), int(np.flatnonzero(sat)[-1])
    assert sat[0]  # the law saturates from the start
    assert np.all(np.abs(aux["u_m"]) <= limit)  # (the actuators clip)
    # relaxed: zero until the first excess acts (on chi_v at once; on chi_b, chi_z, which
    # chi_v drives, a period later), then not
    assert not np.any(chi[: first + 2]) and np.any(chi[first + 2])
    # bounded: never beyond the first command or twice the limit (the feasible rate; measured
    # 1.66 x the limit at 0.12 s planar, the first command spatial); the unaware law winds up
    # well beyond it (measured: 37.6 x the limit planar, 11.5 x spatial)
    assert np.abs(u_c).max() <= max(np.abs(u_c[0]).max(), 2.0 * limit)
    assert np.abs(ignore["u_cmd"]).max() > 1.5 * np.abs(u_c).max()
    # return: the saturation ends, chi decays to a few % of its peak, funnels kept
    assert last < 0.5 * len(u_c)
    assert np.abs(chi[-1]).max() < 0.05 * np.abs(chi).max()
    assert aux.funnel_kept("b") and aux.funnel_kept("z")
    s = aux.summary()
    tol = RELAXED_FRACTION * np.concatenate((aux.rhoinf_b, aux.rhoinf_z))
    relaxed = np.any(np.abs(chi) > tol, axis=1)
    t = np.asarray(aux["t"])
    assert s["first_relaxed_t"] == t[relaxed][0] > 0.0
    assert s["last_relaxed_t"] == t[relaxed][-1] < t[-1]
    assert s["funnel_relaxed_time"] == pytest.approx(relaxed.sum() * (t[1] - t[0]), rel=1e-12)
    assert ignore.summary()["funnel_relaxed_time"] is None  # (no auxiliary system)


@pytest.mark.parametrize("geometry", CASES)
def test_numpy_and_compiled_periods_agree_with_the_auxiliary_system(geometry):
    """The compiled period's auxiliary system is its numpy reference's: the commands and the
    auxiliary states of a saturating closed loop agree to rounding (bound as tests/control/
    test_fast.py's)."""
    name, limit, _ = CASES[geometry]
    sc = _scenario(name, "auxiliary", limit, 0.2)
    runs = {}
    for backend in ("numba", "numpy"):
        setup = prepare(sc)
        if backend == "numpy":
            setup.controller.law.backend = "numpy"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = simulate(setup)
        runs[backend] = np.hstack((res["u_cmd"], res["ctrl_chi_b"], res["ctrl_chi_z"]))
    fast, ref = runs["numba"], runs["numpy"]
    assert np.any(ref[:, -1] != 0.0)  # (the auxiliary system acts)
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-6)
    assert np.max(np.abs(fast - ref) / scale) < 1e-9


@pytest.mark.parametrize("geometry", CASES)
def test_the_option_without_saturation_is_the_paper_law_bit_for_bit(geometry):
    """No limit: chi stays exactly zero and the run is the default's, every signal equal."""
    name, _, _ = CASES[geometry]
    default = _run(_scenario(name, "ignore", None, 0.2))
    aux = _run(_scenario(name, "auxiliary", None, 0.2))
    assert not np.any(aux["ctrl_chi_b"]) and not np.any(aux["ctrl_chi_z"])
    for key in ("q", "v", "u_m", "err_b", "err_z", "w_hat", "theta_d_hat", "w_mc"):
        np.testing.assert_array_equal(aux[key], default[key], err_msg=key)
    assert aux.summary()["funnel_relaxed_time"] == 0.0
    assert aux.summary()["first_relaxed_t"] is None


def test_the_auxiliary_system_is_zero_without_excess_and_its_step_is_exact():
    """The numpy reference's step in closed form: no excess keeps every chi exactly zero; one
    excess du gives chi_v = (1 - exp(-k_v dt)) / k_v M^-1 (0, du), then chi_b and chi_z follow
    L_b and J from chi_v by the exact hold of the next period."""
    term = auxiliary_term(Saturation("auxiliary"), [1.0, 2.0], (2.0, 4.0), 0.01)
    assert term is not None
    aux = AuxiliarySystem(term, nb=3, m3=1, n_task=2)
    M = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]])
    J, L_b = np.array([[1.0, 2.0, 3.0], [0.0, 1.0, -1.0]]), np.eye(1)
    u = np.array([0.5, -2.0])
    assert not np.any(aux.advance(u, u, M, J, L_b))
    assert not np.any(aux.state)
    u = np.array([3.0, -1.0])
    dw = aux.advance(u, u, M, J, L_b)  # excess (-2, 0) on joint 0
    np.testing.assert_allclose(dw, np.linalg.solve(M, [0.0, -2.0, 0.0]), rtol=1e-14)
    chi_v, chi_b, chi_z = aux.parts()
    np.testing.assert_allclose(chi_v, -np.expm1(-4.0 * 0.01) / 4.0 * dw, rtol=1e-14)
    assert not np.any(chi_b) and not np.any(chi_z)  # (driven by chi_v at t: zero)
    v = chi_v.copy()
    aux.advance(np.zeros(2), np.zeros(2), M, J, L_b)
    gain = -np.expm1(-2.0 * 0.01) / 2.0
    np.testing.assert_allclose(chi_z, gain * (J @ v), rtol=1e-14)
    np.testing.assert_allclose(chi_b, gain * v[:1], rtol=1e-14)
    np.testing.assert_allclose(chi_v, np.exp(-4.0 * 0.01) * v, rtol=1e-14)


def test_the_relaxed_time_of_recorded_rows():
    """The summary's relaxation from recorded rows in two blocks (a spilled recording): rows
    whose chi exceeds 1 % of rho_inf count, at the rows' spacing."""
    t = np.arange(8) * 0.5
    chi_z = np.zeros((8, 2))
    chi_z[2:5, 1] = [0.1, 0.02, 0.0015]  # rho_inf 0.1 -> tolerance 1e-3: rows 2, 3, 4
    chi_z[6, 0] = 5e-4  # below the tolerance
    rows = {"t": t, "ctrl_chi_b": np.zeros((8, 1)), "ctrl_chi_z": chi_z}

    def blocks(keys):
        yield {k: rows[k][:3] for k in keys}
        yield {k: rows[k][3:] for k in keys}

    out = relaxation_summary(rows, blocks, ((0.03,), (0.1, 0.1)))
    assert out == {"funnel_relaxed_time": 1.5, "first_relaxed_t": 1.0, "last_relaxed_t": 2.0}
    none = relaxation_summary({"t": t}, blocks, (None, None))
    assert none == dict.fromkeys(out)


def test_the_check_compares_the_first_command_with_the_limits():
    """``--check``'s estimate: the joint with the largest ratio of command to limit, named
    with its ratio; nothing within the limits."""
    text = demand_problem([2.0, -5.0, 1.0], [3.0, 2.0, np.inf], "ignore")
    assert text is not None and "joint 1" in text and "2.5 x" in text
    assert "controller.saturation = 'auxiliary'" in text
    assert demand_problem([2.0, -2.0], [3.0, 2.0], "ignore") is None


def test_bad_saturation_keys_are_one_line():
    """An unknown mode or a rate that is not positive: one line naming the key (and the
    choices); in a scenario file too."""
    with pytest.raises(ParameterError, match="controller.saturation = 'clip': valid choices"):
        Saturation("clip")
    with pytest.raises(ParameterError, match=r"controller.k_v = -1\.0: must be > 0"):
        Saturation("auxiliary", k_v=-1.0)
    text = (
        builtin_path("case1")
        .read_text()
        .replace('scheme = "ppc"', 'scheme = "ppc"\nsaturation = "clip"')
    )
    with pytest.raises(FfsmError) as err:
        scenario_from_toml(text)
    message = str(err.value)
    assert "\n" not in message and "saturation" in message and "auxiliary" in message


def test_the_option_survives_the_saved_scenario():
    """A run's saved scenario.toml keeps the option and its rates (read back equal); the
    default writes no saturation key."""
    from ffsm_pin.scenario.writer import scenario_to_toml

    sc = _scenario("case1", "auxiliary", 3.0, 1.0, k_chi=0.5)
    back = scenario_from_toml(scenario_to_toml(sc))
    assert back.controller.lu_jia.saturation == Saturation("auxiliary", k_chi=0.5)
    assert "saturation" not in scenario_to_toml(builtin_scenario("case1"))
