"""``repeat = "auto"`` (docs/campaigns.md, "How many runs"): run the grid in batches of repeats
until every grid point's funnel-keeping rate is known to +- ``target_half_width`` (the half
width of its 95 % Wilson interval), or ``max_repeat`` draws per grid point.

* The first batch is the fewest runs that could meet the target at all (a rate of 0 or 1,
  where the interval is narrowest): 35 for +- 0.05.
* After each batch, the next repeat count is the most runs any grid point needs for the target
  at its observed rate (rows with an error are not runs), at least a quarter more than now and
  at most twice as many, and never over ``max_repeat``.

The cases of a larger repeat count are the same cases plus new ones (a case's seed depends on
its grid point and repeat index, not on how many there are), so a batch runs only the new ones,
and a campaign resumed in its folder starts from the repeats it already holds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

from .._docstrings import fill_doc
from ._docs import SWEEP_DOC
from .campaign import Campaign
from .cases import Case, expand
from .stats import runs_for_half_width, wilson_half_width

__all__ = ["counts", "grow", "next_repeat", "resumed", "status_text"]


def kept(row: Mapping[str, Any]) -> bool:
    """The row's run kept its funnels over the whole horizon (the report's rate)."""
    return bool(
        row.get("status") == "completed" and row.get("funnel_ok_b") and row.get("funnel_ok_z")
    )


def counts(rows: Iterable[Mapping[str, Any]]) -> dict[int, tuple[int, int]]:
    """Per grid point: (runs that kept their funnels, runs), error rows and nominal cases left
    out."""
    out: dict[int, tuple[int, int]] = {}
    for r in rows:
        if r.get("nominal") or r.get("status") == "error" or r.get("grid_point") is None:
            continue
        k, n = out.get(r["grid_point"], (0, 0))
        out[r["grid_point"]] = (k + kept(r), n + 1)
    return out


def _widest(rows: Iterable[Mapping[str, Any]]) -> float | None:
    widths = [wilson_half_width(k / n, n) for k, n in counts(rows).values() if n]
    return max(widths) if widths else None


def next_repeat(campaign: Campaign, rows: Iterable[Mapping[str, Any]]) -> int | None:
    """The repeat count of the next batch; None when the repeat is fixed, the target is met or
    ``max_repeat`` is reached.

    Parameters
    ----------
    campaign : Campaign
        The campaign.
    rows : iterable of mapping
        Its results table's rows so far.

    Returns
    -------
    int or None
        The repeat count.
    """
    auto, r = campaign.auto, campaign.repeat
    if auto is None or r >= auto.max_repeat:
        return None
    rows = list(rows)
    per_point = counts(rows)
    widest = _widest(rows)
    if widest is not None and widest <= auto.target_half_width:
        return None
    h = auto.target_half_width
    need = max(
        (runs_for_half_width(k / n if n else 0.5, h) + (r - n) for k, n in per_point.values()),
        default=2 * r,
    )  # (r - n: the point's error rows, which are runs no more)
    return min(auto.max_repeat, max(r + max(1, r // 4), min(need, 2 * r)))


def grow(campaign: Campaign, table) -> tuple[Campaign, list[Case], list[Case]] | None:
    """The next batch of an auto-repeat campaign whose rows so far are in the
    :class:`~ffsm_pin.sweep.table.ResultsTable` ``table``: (the campaign with the new repeat
    count, all its cases, the cases still to run); the rows of the earlier ones are renumbered
    in ``table``. None when there is no next batch (:func:`next_repeat`).

    Parameters
    ----------
    campaign : Campaign
        An auto-repeat campaign.
    table : ResultsTable
        Its rows so far.

    Returns
    -------
    tuple or None
        (campaign, all cases, cases to run), or None.
    """
    more = next_repeat(campaign, table.rows.values())
    if more is None:
        return None
    campaign = dataclasses.replace(campaign, repeat=more)
    cases = expand(campaign)
    for case in cases:
        if case.case_hash in table.rows:
            table.keep(table.rows[case.case_hash], case)
    return campaign, cases, [c for c in cases if c.case_hash not in table.rows]


@fill_doc(SWEEP_DOC)
def resumed(
    campaign: Campaign, cases: list[Case], rows: Iterable[Mapping[str, Any]]
) -> tuple[Campaign, list[Case]]:
    """An auto-repeat campaign resumed in a folder: as many repeats as its rows hold (at most
    ``max_repeat``), so that they are kept, not set aside as another campaign's.

    Parameters
    ----------
    %(campaign_cases)s
    rows : iterable of mapping
        The rows the folder holds.

    Returns
    -------
    campaign : Campaign
        With the repeat count the rows hold.
    cases : list of Case
        Its cases.
    """
    if campaign.auto is None:
        return campaign, cases
    held = max((r["repeat"] + 1 for r in rows if r.get("repeat") is not None), default=0)
    repeat = min(campaign.auto.max_repeat, held)
    if repeat <= campaign.repeat:
        return campaign, cases
    campaign = dataclasses.replace(campaign, repeat=repeat)
    return campaign, expand(campaign)


def status_text(campaign: Campaign, rows: Iterable[Mapping[str, Any]]) -> str:
    """One sentence for the report: the target, how many draws it took, met or not.

    Parameters
    ----------
    campaign : Campaign
        The campaign.
    rows : iterable of mapping
        Its results table's rows.

    Returns
    -------
    str
        The sentence; empty when the repeat is fixed.
    """
    auto = campaign.auto
    if auto is None:
        return ""
    widest = _widest(rows)
    got = "-" if widest is None else f"+- {widest:.3f}"
    if widest is not None and widest <= auto.target_half_width:
        how = "met"
    elif campaign.repeat >= auto.max_repeat:
        how = f"not met at the cap of max_repeat = {auto.max_repeat}"
    else:
        how = "not met (the campaign was interrupted)"
    return (
        f'`repeat = "auto"` with a target of +- {auto.target_half_width:g} on every grid '
        f"point's rate (95 % Wilson half-width): {campaign.repeat} draws per grid point, widest "
        f"interval {got}, target {how}."
    )
