"""sweep/stats.py against values worked by hand or published: Clopper-Pearson, Wilson, the
exact McNemar test, run counts."""

from __future__ import annotations

import math

import pytest

from ffsm_pin.sweep.stats import (
    Z95,
    clopper_pearson,
    mcnemar_exact,
    runs_for_half_width,
    runs_to_separate,
    wilson,
    wilson_half_width,
)


def test_clopper_pearson_known_values():
    # 0 of n: upper bound 1 - (alpha/2)^(1/n); 0 of 10 -> 0.3085 (and n of n symmetric)
    lo, hi = clopper_pearson(0, 10)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 10), abs=1e-12)
    assert hi == pytest.approx(0.3085, abs=1e-4)
    assert clopper_pearson(10, 10)[0] == pytest.approx(1 - hi, abs=1e-12)
    # 5 of 10 (Brown, Cai & DasGupta 2001; any table of exact intervals): 0.1871 - 0.8129
    lo, hi = clopper_pearson(5, 10)
    assert (lo, hi) == pytest.approx((0.1871, 0.8129), abs=1e-4)
    assert clopper_pearson(0, 0) == (None, None)


def test_clopper_pearson_is_scipys_exact_interval():
    # the bounds by the beta quantiles are those scipy's binomtest finds by root-finding on the
    # binomial tails (its bracketing stops at about 1e-12), for every count up to n = 60 and
    # for large campaigns, at two levels
    from scipy.stats import binomtest

    cases = [(k, n) for n in range(1, 61) for k in range(n + 1)]
    cases += [(0, 400), (1, 400), (200, 400), (399, 400), (400, 400), (7, 10_000)]
    for level in (0.95, 0.99):
        for k, n in cases:
            ci = binomtest(k, n).proportion_ci(confidence_level=level, method="exact")
            assert clopper_pearson(k, n, level) == pytest.approx((ci.low, ci.high), abs=1e-10)


def test_wilson_known_values_and_wider_exact():
    assert wilson(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)  # Newcombe 1998
    assert wilson(0, 11) == pytest.approx((0.0, 0.2588), abs=1e-4)
    for k, n in ((0, 10), (3, 10), (5, 10), (17, 40)):
        w, c = wilson(k, n), clopper_pearson(k, n)
        assert c[1] - c[0] > w[1] - w[0]
        assert wilson_half_width(k / n, n) == pytest.approx((w[1] - w[0]) / 2)


def test_mcnemar_exact_by_hand():
    # b = 1, c = 9: p = 2 sum_{k <= 1} C(10, k) / 2^10 = 2 (1 + 10) / 1024
    assert mcnemar_exact(1, 9) == pytest.approx(2 * (1 + 10) / 1024) == pytest.approx(0.0215, 1e-3)
    assert mcnemar_exact(9, 1) == mcnemar_exact(1, 9)
    # b = 3, c = 3: symmetric, p = 1; b = 0, c = 5: 2 / 2^5
    assert mcnemar_exact(3, 3) == pytest.approx(1.0)
    assert mcnemar_exact(0, 5) == pytest.approx(2 / 32)
    assert mcnemar_exact(0, 0) == 1.0


def test_runs_for_half_width():
    # at a rate of 0 the Wilson half-width is z^2 / (2 (n + z^2)): n >= z^2 / (2 h) - z^2
    for h in (0.05, 0.1, 0.2):
        assert runs_for_half_width(0.0, h) == math.ceil(Z95**2 / (2 * h) - Z95**2)
    n = runs_for_half_width(0.5, 0.05)
    assert wilson_half_width(0.5, n) <= 0.05 < wilson_half_width(0.5, n - 1)
    assert 370 < n < 390  # about z^2 / (4 h^2) = 384


def test_runs_to_separate_by_hand():
    # p1 = 0.5, p2 = 0.6: (1.95996 sqrt(2 * 0.55 * 0.45) + 0.84162 sqrt(0.25 + 0.24))^2 / 0.01
    root = 1.959964 * math.sqrt(2 * 0.55 * 0.45) + 0.841621 * math.sqrt(0.25 + 0.24)
    assert runs_to_separate(0.5, 0.6) == math.ceil(root**2 / 0.01) == 388
    assert runs_to_separate(0.6, 0.5) == 388
    assert runs_to_separate(0.3, 0.3) is None
    assert runs_to_separate(0.0, 1.0) == math.ceil((1.959964 * math.sqrt(0.5)) ** 2)
