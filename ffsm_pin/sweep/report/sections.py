"""The report's sections that explain and weigh the rates: "Why runs failed", "Paired
comparison" and "How many runs" (docs/campaigns.md)."""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

from ..._docstrings import doc_entries, fill_doc
from ..campaign import SCENARIO_COLUMN
from ..cases import keeps_draws
from ..stats import mcnemar_exact, runs_for_half_width, runs_to_separate, wilson_half_width
from .sql import CONTROLLER_KEY
from .text import f, relabel, table

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    runs="""
        runs : sequence of Row
            Every run (``RUNS_SQL``).""",
    by="""
        by : tuple of str
            Columns grouped by besides the controller.""",
    labels="""
        labels : mapping of str to str
            Controller type -> its label.""",
    returns_list_of_str="""
        Returns
        -------
        list of str
            The section's lines.""",
)

__all__ = [
    "failed_section",
    "how_many_section",
    "paired_rows",
    "paired_section",
    "variant_name",
]

Row = Mapping[str, Any]


def _left(r: Row) -> str:
    if r.get("funnel") is None:
        return "-"
    component = r.get("component")
    return f"{r['funnel']}[{component}]" if component is not None else str(r["funnel"])


@fill_doc(_DOC)
def failed_section(
    failed: list[dict[str, Any]],
    runs: Sequence[Row],
    by: tuple[str, ...],
    labels: Mapping[str, str],
) -> list[str]:
    """The section "Why runs failed": the rows of FAILED_SQL, each with its share of the
    controller's runs (``runs``: every run, RUNS_SQL).

    Parameters
    ----------
    failed : list of dict
        The rows of ``FAILED_SQL``.
    %(runs)s
    %(by)s
    %(labels)s

    %(returns_list_of_str)s
    """
    totals: dict[tuple, int] = {}
    for r in runs:
        key = (*(r[c] for c in by), r["controller"])
        totals[key] = totals.get(key, 0) + 1
    for r in failed:
        n = totals.get((*(r[c] for c in by), r["controller"]), 0)
        r["share"] = f"{r['runs']} of {n}" if n else str(r["runs"])
    relabel(failed, labels, ("controller",))
    lines = [
        "## Why runs failed",
        "",
        "The runs that did not keep both funnels over the whole horizon, per controller: how "
        "they ended (`completed`, or `stopped:` and the `stop_cause`), the funnel and component "
        "first left (`z[i]`: end-effector error component i, position before attitude; "
        "`b[i]`: base attitude error component i; `-`: none was left) and when "
        "(`first_violation_t`, or the stop time when no funnel was left).",
        "",
    ]
    if not failed:
        return [*lines, "Every run kept both funnels.", ""]
    lines += table(
        failed,
        [
            *((c, c, "{}") for c in by),
            ("controller", "controller", "{}"),
            ("outcome", "outcome", "{}"),
            ("left first", None, None),
            ("runs", "share", "{}"),
            ("first at [s]", "first_t", "{:.2f}"),
            ("median [s]", "median_t", "{:.2f}"),
        ],
        extra={"left first": _left},
    )
    return [*lines, ""]


@fill_doc(_DOC)
def paired_rows(runs: Sequence[Row], cols: Sequence[str]) -> list[dict[str, Any]]:
    """Per pair of controller variants (and scenario): the runs of the same grid point (the
    other axes' values) and repeat index, both kept / only A / only B / neither, and the exact
    McNemar p-value; ``common``: every pair drew the same estimates (same seed). A variant is
    the run's values of the varied controller keys (:func:`~ffsm_pin.sweep.cases.keeps_draws`:
    ``controller.type``, options, gains), named by its type alone when only the type varies.

    Parameters
    ----------
    %(runs)s
    cols : sequence of str
        The grid's columns.

    Returns
    -------
    list of dict
        One row per pair.
    """
    scen = [c for c in cols if c == SCENARIO_COLUMN]
    treat = [c for c in cols if c != SCENARIO_COLUMN and keeps_draws(c)]
    others = [c for c in cols if c != SCENARIO_COLUMN and c not in treat]
    cells: dict[tuple, dict[str, dict[tuple, Row]]] = {}
    for r in runs:
        group = tuple(r[c] for c in scen)
        key = (*(str(r[c]) for c in others), r["repeat"])
        cells.setdefault(group, {}).setdefault(variant_name(r, treat), {})[key] = r
    out = []
    for group, per in cells.items():
        for a, b in itertools.combinations(sorted(per), 2):
            common = sorted(set(per[a]) & set(per[b]))
            if not common:
                continue
            pairs = [(per[a][k], per[b][k]) for k in common]
            n = {(x, y): 0 for x in (True, False) for y in (True, False)}
            for ra, rb in pairs:
                n[bool(ra["kept"]), bool(rb["kept"])] += 1
            out.append({
                **dict(zip(scen, group, strict=True)), "a": a, "b": b, "pairs": len(pairs),
                "both": n[True, True], "only_a": n[True, False], "only_b": n[False, True],
                "neither": n[False, False], "p": mcnemar_exact(n[True, False], n[False, True]),
                "common": all(ra["estimates_seed"] == rb["estimates_seed"] for ra, rb in pairs),
            })  # fmt: skip
    return out


def variant_name(run: Row, treat: Sequence[str]) -> str:
    """A run's controller variant: its ``controller.type`` when that is the one varied
    controller key, else ``key=value`` of each (the ``controller.`` prefix left out).

    Parameters
    ----------
    run : mapping
        A row of the run table.
    treat : sequence of str
        The varied controller keys.

    Returns
    -------
    str
        The variant's name.
    """
    if list(treat) == [CONTROLLER_KEY]:
        return str(run[CONTROLLER_KEY])
    return ", ".join(f"{c.removeprefix('controller.')}={run[c]}" for c in treat)


@fill_doc(_DOC)
def paired_section(rows: list[dict[str, Any]], labels: Mapping[str, str]) -> list[str]:
    """The section "Paired comparison" from :func:`paired_rows`.

    Parameters
    ----------
    rows : list of dict
        From :func:`paired_rows`.
    %(labels)s

    %(returns_list_of_str)s
    """
    lines = [
        "## Paired comparison",
        "",
        "Controller variants A and B compared run by run: the runs of the same grid point and "
        "repeat index (the same draw when the estimates' seeds agree: `same draws`). `both`, "
        "`only A`, `only B`, `neither`: pairs by which kept both funnels. p: the exact McNemar "
        "test on the pairs where they differ (the binomial test of `only A` of `only A + only "
        "B` against 1/2, two-sided); a small p says the two keep their funnels at different "
        "rates on the same draws.",
        "",
    ]
    if not rows:
        return [*lines, "No pairs: the controllers share no grid point and repeat index.", ""]
    for r in rows:
        r["a"], r["b"] = labels.get(r["a"], r["a"]), labels.get(r["b"], r["b"])
    has = rows and SCENARIO_COLUMN in rows[0]
    scen = [(SCENARIO_COLUMN, SCENARIO_COLUMN, "{}")] if has else []
    lines += table(
        rows,
        [
            *scen,
            ("A", "a", "{}"),
            ("B", "b", "{}"),
            ("pairs", "pairs", "{}"),
            ("both", "both", "{}"),
            ("only A", "only_a", "{}"),
            ("only B", "only_b", "{}"),
            ("neither", "neither", "{}"),
            ("p (McNemar, exact)", "p", "{:.3g}"),
            ("same draws", None, None),
        ],
        extra={"same draws": lambda r: "yes" if r["common"] else "no"},
    )
    if not all(r["common"] for r in rows):
        lines += [
            "",
            "`same draws = no`: the paired runs drew different estimates (a seed set by hand, "
            "or results of an older version that drew per controller option); the test is "
            "still valid for equal rates, without the precision that common draws give.",
        ]
    return [*lines, ""]


@fill_doc(_DOC)
def how_many_section(
    rates: Sequence[Row], controllers: Sequence[Row], by: tuple[str, ...], auto_text: str
) -> list[str]:
    """The section "How many runs": the widest interval now, the runs a target width needs
    at the observed rates, and the runs that would tell the two closest controllers apart.

    Parameters
    ----------
    rates : sequence of Row
        The rows of ``RATE_SQL``.
    controllers : sequence of Row
        The rows of ``CONTROLLER_SQL``.
    %(by)s
    auto_text : str
        The auto-repeat sentence (:func:`~ffsm_pin.sweep.auto_repeat.status_text`), or empty.

    %(returns_list_of_str)s
    """
    lines = ["## How many runs", ""]
    if auto_text:
        lines += [auto_text, ""]
    known = [r for r in rates if r.get("n")]
    if known:
        widest = max(wilson_half_width(r["rate"], r["n"]) for r in known)
        need = {h: max(runs_for_half_width(r["rate"], h) for r in known) for h in (0.1, 0.05)}
        lines += [
            f"The widest 95 % Wilson interval of a grid point's rate is +- {widest:.3f} "
            f"(with {min(r['n'] for r in known)} to {max(r['n'] for r in known)} runs per grid "
            f"point). At the observed rates, +- 0.10 needs {need[0.1]} runs per grid point and "
            f'+- 0.05 needs {need[0.05]} (`repeat = "auto"` runs batches until a target is met).',
            "",
        ]
    groups: dict[tuple, list[Row]] = {}
    for r in controllers:
        groups.setdefault(tuple(r[c] for c in by), []).append(r)
    for group, rows in groups.items():
        if len(rows) < 2:
            continue
        a, b = min(
            itertools.combinations(rows, 2), key=lambda ab: abs(ab[0]["rate"] - ab[1]["rate"])
        )
        n = runs_to_separate(a["rate"], b["rate"])
        where = f" ({', '.join(str(g) for g in group)})" if group else ""
        head = (
            f"The two closest controllers{where}: {a['controller']} ({f(a['rate'], '{:.0%}')} "
            f"of {a['n']} runs) and {b['controller']} ({f(b['rate'], '{:.0%}')} of {b['n']})."
        )
        if n is None:
            tail = " Their observed rates are equal: no number of runs tells them apart."
        else:
            tail = (
                f" To tell rates this far apart from each other (a two-sided test of two "
                f"proportions, alpha = 0.05, power 0.8, normal approximation) takes about {n} "
                "runs per controller."
            )
        lines += [head + tail, ""]
    return lines
