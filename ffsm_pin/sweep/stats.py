"""The statistics of a campaign's rates (docs/campaigns.md, "How many runs"): 95 % intervals of
a proportion (Wilson score, Clopper-Pearson exact), the exact McNemar test of two controllers
on paired runs, and run counts: for an interval of a given half-width, and to tell two rates
apart.

scipy does the exact binomial arithmetic (``scipy.stats.binomtest``, the beta quantiles of
Clopper-Pearson's bounds) and the normal quantiles.
"""

from __future__ import annotations

import math

from .._docstrings import doc_entries, fill_doc

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    kept="""
        kept : int
            Successes.""",
    n="""
        n : int
            Runs.""",
    z="""
        z : float
            The normal quantile (1.96: 95 %).""",
    returns_lower="""
        Returns
        -------
        lower, upper : float or None
            The interval.""",
    p="""
        p : float
            The observed rate.""",
    params_kept_n_z=("kept", "n", "z"),
    params_p_n_z=("p", "n", "z"),
    params_kept_n=("kept", "n"),
)

__all__ = [
    "Z95", "clopper_pearson", "mcnemar_exact", "runs_for_half_width", "runs_to_separate",
    "wilson", "wilson_half_width",
]  # fmt: skip

Z95 = 1.959963984540054  # standard normal quantile of 0.975


@fill_doc(_DOC)
def wilson(kept: int, n: int, z: float = Z95) -> tuple[float, float] | tuple[None, None]:
    """95 % Wilson score interval of ``kept`` of ``n`` (None, None for n = 0).

    %(params_kept_n_z)s

    %(returns_lower)s
    """
    if n <= 0:
        return None, None
    p = kept / n
    centre, half = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    scale = 1 + z * z / n
    return max((centre - half) / scale, 0.0), min((centre + half) / scale, 1.0)


@fill_doc(_DOC)
def wilson_half_width(p: float, n: int, z: float = Z95) -> float:
    """Half the width of the Wilson interval at an observed rate ``p`` of ``n`` runs.

    %(params_p_n_z)s

    Returns
    -------
    float
        The half-width.
    """
    return z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)


@fill_doc(_DOC)
def clopper_pearson(
    kept: int, n: int, level: float = 0.95
) -> tuple[float, float] | tuple[None, None]:
    """Exact (Clopper-Pearson) interval of ``kept`` of ``n`` (None, None for n = 0): never
    narrower than its level promises, so wider than Wilson's.

    %(params_kept_n)s
    level : float
        Confidence level.

    %(returns_lower)s
    """
    if n <= 0:
        return None, None
    from scipy.special import betaincinv

    # the bounds are quantiles of beta distributions (Clopper & Pearson 1934): what
    # scipy.stats.binomtest(...).proportion_ci(method="exact") finds by root-finding on the
    # binomial tail (27 ms a call, most of a campaign report's statistics), in one call of the
    # inverse regularised incomplete beta function (tests/sweep/test_stats.py: the same to 1e-10)
    k, n, tail = int(kept), int(n), (1.0 - level) / 2
    lower = 0.0 if k == 0 else float(betaincinv(k, n - k + 1, tail))
    upper = 1.0 if k == n else float(betaincinv(k + 1, n - k, 1.0 - tail))
    return lower, upper


def mcnemar_exact(only_a: int, only_b: int) -> float:
    """Two-sided exact McNemar p-value from the discordant pairs (A kept and B not: ``only_a``;
    the reverse: ``only_b``): the binomial test of ``only_a`` of ``only_a + only_b`` against
    1/2. 1.0 without discordant pairs.

    Parameters
    ----------
    only_a : int
        Pairs A kept and B did not.
    only_b : int
        The reverse.

    Returns
    -------
    float
        The p-value.
    """
    if only_a + only_b == 0:
        return 1.0
    from scipy.stats import binomtest

    return float(binomtest(int(only_a), int(only_a + only_b), 0.5).pvalue)


@fill_doc(_DOC)
def runs_for_half_width(p: float, half_width: float, z: float = Z95) -> int:
    """The fewest runs whose Wilson interval at an observed rate ``p`` is no wider than
    +- ``half_width`` (the half-width falls with n at any fixed p).

    Parameters
    ----------
    %(p)s
    half_width : float
        The half-width aimed at.
    %(z)s

    Returns
    -------
    int
        The runs.
    """
    lo, hi = 1, 2
    while wilson_half_width(p, hi, z) > half_width:
        lo, hi = hi, 2 * hi
    while lo < hi:  # the smallest n in [lo, hi] that meets it
        mid = (lo + hi) // 2
        if wilson_half_width(p, mid, z) > half_width:
            lo = mid + 1
        else:
            hi = mid
    return hi


def runs_to_separate(p1: float, p2: float, alpha: float = 0.05, power: float = 0.8) -> int | None:
    """Runs per controller to tell rates ``p1`` and ``p2`` apart.

    A two-sided test of two proportions at level ``alpha`` detects the difference with
    probability ``power`` after n runs of each, in the normal approximation (Fleiss,
    Statistical Methods for Rates and Proportions, without continuity correction):

        n = (z_{1-alpha/2} sqrt(2 pbar qbar) + z_{power} sqrt(p1 q1 + p2 q2))^2 / (p1 - p2)^2.

    None when the rates are equal (no number of runs tells them apart).

    Parameters
    ----------
    p1, p2 : float
        The two rates.
    alpha : float
        The test's level.
    power : float
        The probability of detecting the difference.

    Returns
    -------
    int or None
        Runs per controller.
    """
    if p1 == p2:
        return None
    from scipy.stats import norm

    za, zb = float(norm.ppf(1 - alpha / 2)), float(norm.ppf(power))
    pbar = (p1 + p2) / 2
    root = za * math.sqrt(2 * pbar * (1 - pbar)) + zb * math.sqrt(p1 * (1 - p1) + p2 * (1 - p2))
    return math.ceil(root * root / (p1 - p2) ** 2)
