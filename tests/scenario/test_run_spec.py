"""The scenario describes the run, not one controller (issue 36): the performance specification
every run is judged by (``Scenario.performance``: the funnels, the singularity threshold) apart
from the lu-jia controller's own parameters (``ControllerSpec.lu_jia``, declared and validated
by the controller, control/lu_jia_params.py); the run loop names no controller; every shipped
scenario and campaign file still loads and round-trips."""

from __future__ import annotations

import dataclasses
import re
import sys
import textwrap
from pathlib import Path

import pytest

import ffsm_pin.sim
from ffsm_pin.control.adaptive_ct import AdaptiveCtGains
from ffsm_pin.control.gains import SingularityPolicy
from ffsm_pin.control.gjm_ct import GjmGains
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.control.lu_jia_params import GAIN_KEYS, LuJiaKeys, LuJiaParams
from ffsm_pin.control.registry import BUILTIN as CONTROLLER_TYPES
from ffsm_pin.errors import FfsmError, ScenarioError
from ffsm_pin.scenario import builtin_scenario, scenario_from_toml, scenario_to_toml
from ffsm_pin.scenario.file import BUILTIN, builtin_path, load_scenario, scenario_from_dict
from ffsm_pin.scenario.sections import ControllerModel
from ffsm_pin.scenario.spec import Performance
from ffsm_pin.sim.run import prepare, simulate
from ffsm_pin.sweep.campaign import BUILTIN_CAMPAIGNS, load_campaign
from ffsm_pin.sweep.cases import expand

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
SIM = Path(ffsm_pin.sim.__file__).parent


def _case1_doc() -> dict:
    return tomllib.loads(builtin_path("case1").read_text())


# ------------------------------------------------------------------------------ the model
def test_performance_and_the_lu_jia_params_are_apart():
    sc = builtin_scenario("case1")
    perf, p = sc.performance, sc.controller.lu_jia
    assert isinstance(perf, Performance) and isinstance(p, LuJiaParams)
    assert perf.funnel_b.rho0 == (1.0,) and perf.singularity_threshold == 0.05
    assert p.scheme == "ppc" and p.max_damped_time == 10.0
    assert sc.controller.scheme == p.scheme  # the read-only shortcut
    assert p.policy(perf.singularity_threshold) == SingularityPolicy(0.05, 10.0)
    for name in ("funnel_b", "funnel_z", "gains", "null_space", "singularity"):
        assert not hasattr(sc.controller, name), name  # not the controller spec's any more


def test_the_lu_jia_controller_declares_its_keys():
    """The file's [controller] table is the lu-jia controller's keys plus the run's own."""
    assert LuJiaController.params_model is LuJiaParams
    assert issubclass(ControllerModel, LuJiaKeys)
    own = set(LuJiaKeys.model_fields)
    assert own == {"scheme", *GAIN_KEYS, "null_space", "singularity", "saturation", "k_chi", "k_v",
                   "adaptation", "physical_margin"}  # fmt: skip
    assert set(ControllerModel.model_fields) - own == {"type", "params", "funnel", "estimates"}


@pytest.mark.parametrize(
    ("key", "value", "fragments"),
    [
        ("scheme", "ppcc", ("controller.scheme = 'ppcc' unknown", "did you mean 'ppc'?",
                            "valid choices: 'ppc', 'no-ppc', 'no-attitude', 'known-model'")),
        ("scheme", 3, ("controller.scheme: expected a string",)),
        ("k_z", -0.1, ("controller.k_z = -0.1: must be > 0",)),
        ("gamma_2", "10", ("controller.gamma_2: expected a number",)),
        ("k_zz", 0.1, ("controller.k_zz: unknown key in [controller]", "did you mean 'k_z'?",
                       "valid keys:", "'gamma_3'", "'funnel'")),
        ("null_space", {"objective": "manipulabilty"},
         ("controller.null_space.objective = 'manipulabilty' unknown",
          "did you mean 'manipulability'?", "valid choices: 'none', 'manipulability', "
          "'joint-centering'")),
        ("null_space", {"gain": -1.0}, ("controller.null_space.gain = -1.0: must be >= 0",)),
        ("null_space", {"center": [0.0] * 4},
         ("controller.null_space.center: only used with objective = 'joint-centering'",)),
        ("null_space", {"objective": "joint-centering", "center": "zero"},
         ("controller.null_space.center: expected a list of numbers",)),
        ("singularity", {"max_damped_time": 0.0},
         ("controller.singularity.max_damped_time = 0.0: must be > 0",)),
        ("singularity", {"max_damped": 1.0},
         ("controller.singularity.max_damped: unknown key in [controller.singularity]",
          "did you mean 'max_damped_time'?", "'threshold'")),
        ("singularity", {"threshold": 0.0},
         ("controller.singularity.threshold = 0.0: must be > 0",)),
    ],
)  # fmt: skip
@pytest.mark.parametrize("kind", ["lu-jia", "gjm-ct"])
def test_lu_jia_keys_are_refused_in_one_line_naming_the_key(key, value, fragments, kind):
    """Validated the same whatever the type (CONTRACT: the paper's keys may be given for any
    type, and are used where a controller uses them)."""
    d = _case1_doc()
    d["controller"]["type"] = kind
    d["controller"][key] = value
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    text = str(info.value)
    assert "\n" not in text
    for fragment in fragments:
        assert fragment in text, text


def test_bad_backend_param_is_one_line():
    sc = builtin_scenario("case1")
    sc = dataclasses.replace(
        sc, controller=dataclasses.replace(sc.controller, params={"backend": "fast"})
    )
    with pytest.raises(FfsmError) as info:
        prepare(sc)
    assert str(info.value) == (
        "controller.params.backend = 'fast': valid choices: 'auto', 'numba', 'numpy'"
    )


def test_the_lu_jia_controller_ignores_other_controllers_params():
    """As before: a campaign over several types may share one [controller.params] table (the
    keys of another type are left to it; [campaign.set_for_controller] keeps them apart)."""
    sc = builtin_scenario("case1")
    sc = dataclasses.replace(
        sc, controller=dataclasses.replace(sc.controller, params={"kp": 40.0}), duration=0.01
    )
    assert simulate(prepare(sc)).completed


def test_the_baselines_declare_their_params_keys():
    """The keys they accept are the fields of their gains (checked before they are built)."""
    for kind, gains in (("gjm-ct", GjmGains), ("adaptive-ct", AdaptiveCtGains)):
        keys = tuple(f.name for f in dataclasses.fields(gains))
        assert CONTROLLER_TYPES[kind].params_keys == keys
    assert not hasattr(LuJiaController, "params_keys")  # it leaves other types' keys alone


@pytest.mark.parametrize(
    ("kind", "params", "message"),
    [
        ("gjm-ct", {"k_vv": 1.0}, "controller.params.k_vv: unknown for controller.type 'gjm-ct' "
                                  "(did you mean 'k_v'?); valid keys: 'k_z', 'k_v'"),
        ("adaptive-ct", {"kp": 1.0}, "controller.params.kp: unknown for controller.type "
                                     "'adaptive-ct'; valid keys: 'k_z', 'k_s', 'gamma_b', "
                                     "'gamma_z', 'gamma_d'"),
        ("mine.py:Declared", {"gain": 2.0}, "controller.params.gain: unknown for controller.type "
                                            "'mine.py:Declared' (did you mean 'gains'?); valid "
                                            "keys: 'gains', 'target'"),
        ("mine.py:NoKeys", {"gain": 2.0}, "controller.params.gain: unknown for controller.type "
                                          "'mine.py:NoKeys'; valid keys: none"),
    ],
)  # fmt: skip
def test_declared_params_keys_refuse_others_in_one_line(kind, params, message, tmp_path):
    (tmp_path / "mine.py").write_text(
        textwrap.dedent("""
        class Declared:
            params_keys = ("gains", "target")

            def __init__(self, ctx):
                raise AssertionError("never built with a key it does not declare")

            def step(self, meas):
                return None

        class NoKeys(Declared):
            params_keys = ()
    """)
    )
    d = _case1_doc()
    d["controller"]["type"] = kind
    d["controller"]["params"] = params
    with pytest.raises(FfsmError) as info:
        prepare(scenario_from_dict(d, source=tmp_path / "case.toml"))
    assert str(info.value) == message


@pytest.mark.parametrize("kind", ["gjm-ct", "adaptive-ct"])
def test_baselines_read_the_performance_spec(kind):
    """Their default gains come from the run's end-effector funnel and they damp below the
    run's singularity threshold (not from the lu-jia controller's keys)."""
    d = _case1_doc()
    d["controller"]["type"] = kind
    d["controller"]["singularity"] = {"threshold": 0.02, "max_damped_time": 1.0}
    d["controller"]["funnel"]["beta_z"] = 0.5
    setup = prepare(scenario_from_dict(d))
    ctrl = setup.controller
    assert ctrl.threshold == 0.02
    assert ctrl.gains.k_z[2] == pytest.approx(2 * 0.5)  # 2 beta_z on the attitude component
    if kind == "adaptive-ct":  # the paper's adaptation gains, its documented defaults
        g = setup.scenario.controller.lu_jia.gains
        assert (ctrl.gains.gamma_b, ctrl.gains.gamma_z, ctrl.gains.gamma_d) == (
            g.gamma_1, g.gamma_2, g.gamma_3,
        )  # fmt: skip


# ------------------------------------------------------------------------------ the loop
def test_the_run_loop_names_no_controller():
    """Nothing in ffsm_pin/sim names a controller type: what the summary says of a controller
    (its scheme) it asks the controller, what it judges by is the performance spec."""
    for path in sorted(SIM.glob("*.py")):
        text = path.read_text()
        for kind in CONTROLLER_TYPES:
            assert kind not in text, f"{path.name} names {kind!r}"
        assert "LuJia" not in text and "lu_jia" not in text, path.name


def test_the_summary_reports_the_controllers_own_scheme(tmp_path):
    """``scheme`` in summary.json is the controller's attribute: the paper's controller's
    variant, a user's controller's own label, null for the baselines; ``min_sigma_of`` is the
    controller's ``sigma_measure``."""
    (tmp_path / "mine.py").write_text(
        textwrap.dedent("""
        import numpy as np

        class Labelled:
            scheme = "my-variant"

            def __init__(self, ctx):
                self.n = ctx.n_joints

            def step(self, meas):
                return np.zeros(self.n)

        class NotAString(Labelled):
            scheme = 3
    """)
    )
    base = _case1_doc()
    base["sim"] = {"duration": 0.01, "dt": 0.001}
    for kind, scheme, measure in (
        ("lu-jia", "ppc", "J_m-hat U-hat"), ("gjm-ct", None, "J*-hat"),
        ("adaptive-ct", None, "J*-hat"), ("mine.py:Labelled", "my-variant", None),
        ("mine.py:NotAString", None, None),
    ):  # fmt: skip
        d = {**base, "controller": {**base["controller"], "type": kind}}
        sc = scenario_from_dict(d, source=tmp_path / "case.toml")
        summary = simulate(prepare(sc)).summary()
        assert summary["scheme"] == scheme, kind
        assert summary["min_sigma_of"] == measure, kind  # (None: no sigma_min reported)
        assert summary["controller"] == kind
        assert summary["damping_threshold"] == sc.performance.singularity_threshold


# ------------------------------------------------------------------------------ the files
SCENARIO_FILES = sorted(
    [builtin_path(name) for name in BUILTIN]
    + [p for p in (REPO / "examples").glob("*.toml")]
    + [p for p in (REPO / "tests").rglob("*.toml") if "[initial]" in p.read_text()]
    + [p for p in (REPO / "docs").rglob("scenario.toml")]
)


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: str(p.relative_to(REPO)))
def test_every_shipped_scenario_file_loads_and_round_trips(path):
    sc = load_scenario(path)
    text = scenario_to_toml(sc)
    again = scenario_from_toml(text)
    assert scenario_to_toml(again) == text
    assert again.performance == sc.performance
    assert again.controller.lu_jia == sc.controller.lu_jia
    assert again.controller.type.endswith(sc.controller.type.split("/")[-1])


@pytest.mark.parametrize(
    "source",
    sorted(BUILTIN_CAMPAIGNS) + sorted(str(p) for p in (REPO / "docs").rglob("campaign.toml")),
    ids=lambda s: Path(s).parent.name if "/" in s else s,
)
def test_every_shipped_campaign_loads_and_its_cases_round_trip(source):
    cases = expand(load_campaign(source))
    assert cases
    for case in cases:
        again = scenario_from_toml(case.scenario_toml)
        assert scenario_to_toml(again) == case.scenario_toml
        assert again.performance == case.scenario.performance


def test_old_error_paths_keep_their_words():
    """The messages a user knew keep naming the file's keys (controller.funnel...,
    controller.singularity.threshold), whichever object holds the value now."""
    d = _case1_doc()
    d["controller"]["funnel"]["rho_zinf"] = [2.0, 0.08, 0.05]
    with pytest.raises(ScenarioError, match=re.escape("controller.funnel.rho_zinf[0] = 2.0")):
        scenario_from_dict(d)
