"""Gains and singularity policy (ffsm_pin.control.gains): frozen, validated, the paper's
Section 4 values by default."""

from __future__ import annotations

import dataclasses
import math

import pytest

from ffsm_pin.control.gains import Gains, SingularityPolicy
from ffsm_pin.errors import ParameterError

GAIN_FIELDS = [f.name for f in dataclasses.fields(Gains)]
POLICY_FIELDS = [f.name for f in dataclasses.fields(SingularityPolicy)]
BAD_VALUES = [0, 0.0, -1.0, -1e-12, math.nan, math.inf, -math.inf, "1.0", None]


def test_defaults_are_the_papers_gains():
    # Section 4: k_b = 0.04, Gamma_1 = 10, k_z = 0.04, Gamma_2 = 10, k_de = 0.3, k_d = 0.8,
    # Gamma_3 = 10
    assert Gains() == Gains(
        k_b=0.04, k_z=0.04, k_de=0.3, k_d=0.8, gamma_1=10.0, gamma_2=10.0, gamma_3=10.0
    )
    assert set(GAIN_FIELDS) == {"k_b", "k_z", "k_de", "k_d", "gamma_1", "gamma_2", "gamma_3"}


@pytest.mark.parametrize("name", GAIN_FIELDS)
@pytest.mark.parametrize("value", BAD_VALUES)
def test_gains_reject_non_positive_or_non_finite(name, value):
    with pytest.raises(ParameterError, match=rf"Gains\.{name}\b"):
        Gains(**{name: value})


@pytest.mark.parametrize("name", POLICY_FIELDS)
@pytest.mark.parametrize("value", BAD_VALUES)
def test_policy_rejects_non_positive_or_non_finite(name, value):
    with pytest.raises(ParameterError, match=rf"SingularityPolicy\.{name}\b"):
        SingularityPolicy(**{name: value})


@pytest.mark.parametrize("name", GAIN_FIELDS)
def test_gains_accept_any_positive_value(name):
    for value in (1e-9, 1, 2.5, 1e9):
        assert getattr(Gains(**{name: value}), name) == value


def test_policy_accepts_positive_values():
    p = SingularityPolicy(threshold=1e-4, max_damped_time=0.5)
    assert (p.threshold, p.max_damped_time) == (1e-4, 0.5)


@pytest.mark.parametrize("obj", [Gains(), SingularityPolicy()])
def test_frozen(obj):
    name = dataclasses.fields(obj)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(obj, name, 1.0)
