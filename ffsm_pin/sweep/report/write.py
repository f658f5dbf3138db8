"""report.md: the sections in order, from the queries of :mod:`.sql`, the statistics of
:mod:`ffsm_pin.sweep.stats`, the sections of :mod:`.sections` and the figures of
:mod:`.figures`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..auto_repeat import status_text
from ..campaign import SCENARIO_COLUMN, Campaign
from ..cases import keeps_draws
from ..stats import clopper_pearson
from .figures import figures, overlay_figures
from .sections import failed_section, how_many_section, paired_rows, paired_section
from .sql import (
    CAUSES_SQL,
    CONTROLLER_KEY,
    FAILED_SQL,
    KEPT,
    N_WORST,
    POINTS_EXTRA,
    POINTS_SQL,
    RATE_SQL,
    RUNS_EXTRA,
    RUNS_SQL,
    SPREAD_EXTRA,
    SPREAD_SQL,
    WORST_SQL,
    by_sel,
    controller_sql,
    extra,
    present,
    query,
    quoted,
    sql,
)
from .text import controller_labels, f, interval, kept_text, relabel, table

__all__ = ["write_report"]


def write_report(out: Path, campaign: Campaign) -> Path:
    """Write ``report.md``, its figures (``fig_*.png``) and the worst cases' scenario files
    (``worst/case-NNNNN.toml``) into ``out``; return the report's path.

    Parameters
    ----------
    out : Path
        The campaign folder (``results.parquet`` in it).
    campaign : Campaign
        The campaign.

    Returns
    -------
    Path
        ``report.md``.
    """
    path = out / "results.parquet"
    have = present(path)
    cols = list(campaign.axes)
    by = tuple(c for c in cols if c == SCENARIO_COLUMN)
    labels = _labels(path, have)
    lab_keys = (CONTROLLER_KEY, "controller")
    q = {
        "rate": sql(RATE_SQL, path, cols),
        "spread": sql(SPREAD_SQL, path, cols, extra=extra(SPREAD_EXTRA, have)),
        "worst": sql(WORST_SQL, path, cols),
        "causes": sql(CAUSES_SQL, path, cols),
    }
    rates, spread, worst, causes = (query(q[k]) for k in ("rate", "spread", "worst", "causes"))
    points = query(sql(POINTS_SQL, path, cols, extra=extra(POINTS_EXTRA, have, comma_first=True)))
    runs = query(sql(RUNS_SQL, path, cols, extra=extra(RUNS_EXTRA, have, comma_first=True)))
    for rows in (rates, spread, worst, points, causes):
        relabel(rows, labels, lab_keys)
    for r in rates:
        r["exact_lo"], r["exact_hi"] = clopper_pearson(r["kept"], r["n"])
    nominal = query(f"SELECT * FROM read_parquet('{quoted(path)}') WHERE nominal ORDER BY 1")
    errors = query(
        f"SELECT \"case\", error FROM read_parquet('{quoted(path)}') WHERE status = 'error' "
        "ORDER BY 1"
    )
    total = query(
        f"SELECT count(*) AS n, sum(wall_time_s) AS wall FROM read_parquet('{quoted(path)}')"
    )[0]
    files = figures(out, cols, rates, points)
    auto = status_text(campaign, query(
        'SELECT grid_point, nominal, status, funnel_ok_b, funnel_ok_z '
        f"FROM read_parquet('{quoted(path)}')"
    )) if campaign.auto is not None else ""  # fmt: skip

    lines = _head(out, campaign, total, auto)
    if "blas" in have:  # what the rows were computed with (null in rows run before the column)
        lines += _computed_with(path)
    lines += _nominal(nominal, by)
    controllers: list[dict[str, Any]] = []
    if CONTROLLER_KEY in cols:
        controllers = query(controller_sql(path, by, have))
        lines += _controller_section(path, by, have, controllers, labels)
    lines += _rates(cols, rates, causes, files["rate"])
    if "first_violation_funnel" in have:
        failed = query(sql(FAILED_SQL, path, by=by_sel(by)))
        q["failed"] = sql(FAILED_SQL, Path("results.parquet"), by=by_sel(by))
        lines += failed_section(failed, runs, by, labels)
    if any(keeps_draws(c) for c in cols if c != SCENARIO_COLUMN):  # controller variants
        lines += paired_section(paired_rows(runs, cols), labels)
    lines += how_many_section(rates, controllers, by, auto)
    lines += _spread(cols, spread, files, have)
    lines += _overlays(out, runs, by, labels)
    lines += _worst(out, cols, worst)
    if errors:
        lines += ["", "## Cases that failed with an error", ""]
        lines += [f"* case {r['case']}: {r['error']}" for r in errors]
    lines += _queries(cols, by, have, "failed" in q)
    report = out / "report.md"
    report.write_text("\n".join(lines), encoding="utf-8")
    return report


def _labels(path: Path, have: set[str]) -> dict[str, str]:
    """Short labels of the controller types in the file (its summary column ``controller``
    and the varied ``controller.type``)."""
    kinds: dict[str, str | None] = {}
    for col in ("controller", CONTROLLER_KEY):
        if col in have:
            rows = query(
                f'SELECT "{col}" AS kind, any_value(scenario_toml) AS toml '
                f"FROM read_parquet('{quoted(path)}') WHERE \"{col}\" IS NOT NULL GROUP BY 1"
            )
            kinds.update({str(r["kind"]): r["toml"] for r in rows})
    return controller_labels(kinds)


def _computed_with(path: Path) -> list[str]:
    """The BLAS kernels and library versions the rows were computed with, and what a mix of
    kernels means (docs/REPRODUCTION.md, "Reproducing the shipped numbers on another CPU")."""
    groups = query(
        f"SELECT blas, versions, count(*) AS n FROM read_parquet('{quoted(path)}') "
        "WHERE blas IS NOT NULL GROUP BY ALL ORDER BY n DESC, blas, versions"
    )
    if not groups:
        return []
    lines = ["Computed with " + "; ".join(
        f"{g['blas']} ({g['versions']}): {g['n']} rows" for g in groups
    ) + "."]  # fmt: skip
    if len({g["blas"] for g in groups}) > 1:
        lines[0] += (
            " Rows computed with other BLAS kernels part from each other by rounding grown along "
            "each run; `OPENBLAS_CORETYPE` in the environment gives every worker the same ones."
        )
    return lines + [""]


def _head(out: Path, campaign: Campaign, total, auto: str) -> list[str]:
    lines = [f"# Campaign `{campaign.name}`", ""]
    if campaign.description:
        lines += [campaign.description, ""]
    scen = (
        f"Scenario `{campaign.scenario}`"
        if len(campaign.scenarios) == 1
        else "Scenarios " + ", ".join(f"`{x}`" for x in campaign.scenarios)
    )
    nominal = (
        "case 0 is the nominal scenario"
        if len(campaign.scenarios) == 1
        else "the first case of each scenario is its nominal run"
    )
    lines += [
        f"{scen}, root seed {campaign.seed}, {campaign.repeat} draws per grid point, "
        f"{campaign.n_cases} cases ({nominal}); {total['n']} rows in `results.parquet`, "
        f"{f(total['wall'], '{:.0f}')} s of simulation wall time in total.",
        "",
    ]
    if auto:
        lines += [auto, ""]
    arg = _campaign_arg(campaign)
    where = (
        "from the repository root"  # a built-in campaign, its report shipped in docs/
        if arg == campaign.name
        else "from any folder: the campaign file and this folder by their absolute paths"
    )
    folder = out if arg == campaign.name else Path(out).resolve()
    lines += [
        f"Reproduce ({where}; an existing folder is resumed, `--force` re-runs):",
        "",
        "```bash",
        f"python -m ffsm_pin.sweep {arg} --out {folder}",
        "```",
        "",
        "A case **keeps its funnels** when it runs the whole horizon with both funnels kept "
        f"(`{KEPT}`). Runs that stop early (funnel left, arm singular too long, blow-up) count "
        "as not kept; rows with `status = 'error'` are not runs and are left out of the rates.",
        "",
    ]
    return lines


def _nominal(nominal, by) -> list[str]:
    if not nominal:
        return []
    lines = ["## Nominal case" + ("s" if len(nominal) > 1 else ""), ""]
    for r in nominal:
        which = f"the scenario `{r['scenario']}`" if by else "the scenario"
        lines += [
            f"Case {r['case']}, {which} as shipped: status `{r['status']}`, funnels "
            f"{kept_text(r.get('funnel_ok_b'))} / {kept_text(r.get('funnel_ok_z'))} (b / z), "
            f"max |u_m| = {f(r.get('max_abs_u'), '{:.4g}')} N m (norm), settle time z = "
            f"{f(r.get('settle_time_z'), '{:.2f}')} s, min sigma = "
            f"{f(r.get('min_sigma'), '{:.3g}')} m.",
            "",
        ]
    return lines


def _rate_cell(r, rate: str, kept: str) -> str:
    lo, hi = clopper_pearson(r[kept], r["n"])
    return (
        f"{f(r[rate], '{:.0%}')} ({interval(r[rate + '_lo'], r[rate + '_hi'])}; "
        f"exact {interval(lo, hi)})"
    )


def _saturation(path: Path, by, have) -> dict[tuple, str]:
    """Per (by..., controller): the mean over runs of each joint's share of periods at its
    torque limit, as "0% / 12% / 3%"."""
    if "saturation_per_joint" not in have:
        return {}
    rows = query(
        f'SELECT {by_sel(by)}"{CONTROLLER_KEY}" AS controller, saturation_per_joint '
        f"FROM read_parquet('{quoted(path)}') WHERE NOT nominal AND status <> 'error' "
        "AND saturation_per_joint IS NOT NULL"
    )
    per: dict[tuple, list[list[float]]] = {}
    for r in rows:
        per.setdefault((*(r[c] for c in by), r["controller"]), []).append(r["saturation_per_joint"])
    out = {}
    for key, lists in per.items():
        n = min(len(x) for x in lists)
        means = [sum(x[i] for x in lists) / len(lists) for i in range(n)]
        out[key] = " / ".join(f"{m:.0%}" for m in means)
    return out


def _controller_section(path: Path, by, have, rows, labels) -> list[str]:
    """report.md's per-controller table (campaigns that vary controller.type)."""
    sat = _saturation(path, by, have)
    for r in rows:
        r["per_joint"] = sat.get((*(r[c] for c in by), r["controller"]), "-")
    relabel(rows, labels, ("controller",))
    lines = [
        "## Per controller" + (" and scenario" if by else ""),
        "",
        "Over every grid point of each controller (medians over its runs; rates with 95 % "
        "Wilson and exact Clopper-Pearson intervals). `kept b+z`: the whole horizon with both "
        "funnels kept; `kept z`: with the end-effector funnel kept (a controller that leaves the "
        "base attitude free, as gjm-ct, is judged on this one). RMS e_z: over the last half of "
        "each run; max |u_i|: the largest joint torque applied; max norm: the largest Euclidean "
        "norm of the torque vector; saturated: share of control periods with some joint at its "
        "limit, and per joint (mean over runs); effort: integral of |u_m|^2 dt; excursion: "
        "largest base rotation from its initial attitude; sigma_min(J*): the smallest singular "
        "value of the true model's generalized Jacobian (task rows) over a run, the same "
        "measure for every controller; own sigma_min: the one each controller damps, of the "
        "matrix named beside it.",
        "",
    ]
    cols = [
        *((c, c, "{}") for c in by),
        ("controller", "controller", "{}"),
        ("runs", "n", "{}"),
        ("kept b+z", None, None),
        ("kept z", None, None),
        ("RMS e_z", "rms_err_z_late", "{:.3g}"),
        *([("max abs u_i [N m]", "max_joint_torque", "{:.4g}")] if "max_joint_torque" in have
          else []),
        ("max norm u_m [N m]", "max_abs_u", "{:.4g}"),
        ("saturated", "saturation_fraction", "{:.1%}"),
        *([("saturated per joint", "per_joint", "{}")] if sat else []),
        ("effort [N^2 m^2 s]", "control_effort", "{:.4g}"),
        ("excursion [rad]", "max_base_excursion", "{:.3g}"),
        ("settled z", "settled_z", "{}"),
        ("settle z [s]", "settle_time_z", "{:.2f}"),
        *([("sigma_min(J*) [m]", "min_sigma_gjm", "{:.3g}")] if "min_sigma_gjm" in have else []),
        *([("own sigma_min", None, None)] if "min_sigma_of" in have else []),
    ]  # fmt: skip
    lines += table(
        rows,
        cols,
        extra={
            "kept b+z": lambda r: _rate_cell(r, "rate", "kept"),
            "kept z": lambda r: _rate_cell(r, "rate_z", "kept_z"),
            "own sigma_min": lambda r: (
                f"{f(r.get('min_sigma'), '{:.3g}')} ({r.get('min_sigma_of') or '-'})"
            ),
        },
    )
    return lines + [""]


def _rates(cols, rates, causes, figure: str) -> list[str]:
    lines = ["## Funnel-keeping rate per grid point (95 % intervals)", ""]
    lines += table(
        rates,
        [
            *((c, c, None) for c in cols),
            ("runs", "n", "{}"),
            ("kept", "kept", "{}"),
            ("rate", "rate", "{:.0%}"),
            ("95 % Wilson", None, None),
            ("95 % exact", None, None),
            ("stopped early", "stopped", "{}"),
            ("errors", "errors", "{}"),
        ],
        extra={
            "95 % Wilson": lambda r: interval(r["rate_lo"], r["rate_hi"]),
            "95 % exact": lambda r: interval(r["exact_lo"], r["exact_hi"]),
        },
    )
    lines += [
        "",
        "Wilson: the score interval; exact: Clopper-Pearson, which never covers less than 95 % "
        "and so is wider.",
        "",
        f"![funnel-keeping rate]({figure})",
        "",
    ]
    if causes:
        lines += ["Why runs stopped early (from `stop_reason`):", ""]
        lines += table(
            causes,
            [
                *((c, c, None) for c in cols),
                ("cause", "cause", "{}"),
                ("runs", "runs", "{}"),
                ("first stop [s]", "first_stop", "{:.2f}"),
                ("median stop [s]", "median_stop", "{:.2f}"),
            ],
        )
        lines += [""]
    return lines


def _spread(cols, spread, files, have) -> list[str]:
    lines = ["## Control effort, settling and distance to singularity per grid point", ""]
    joint = "max_joint_torque" in have
    gjm = "min_sigma_gjm" in have
    lines += table(
        spread,
        [
            *((c, c, None) for c in cols),
            *([("max abs u_i: median [N m]", "u_joint_median", "{:.4g}"),
               ("max abs u_i: max", "u_joint_max", "{:.4g}")] if joint else []),
            ("max norm u_m: median [N m]", "u_median", "{:.4g}"),
            ("95th pct", "u_p95", "{:.4g}"),
            ("max", "u_max", "{:.4g}"),
            ("settled z", "settled_z", "{}"),
            ("settle z median [s]", "settle_z_median", "{:.2f}"),
            ("settle z max [s]", "settle_z_max", "{:.2f}"),
            ("settle b median [s]", "settle_b_median", "{:.2f}"),
            *([("min sigma_min(J*) [m]", "gjm_min", "{:.3g}"),
               ("median", "gjm_median", "{:.3g}")] if gjm else []),
            ("min own sigma [m]", "sigma_min", "{:.3g}"),
            ("median own sigma [m]", "sigma_median", "{:.3g}"),
        ],
    )  # fmt: skip
    lines += [
        "",
        "`settled z`: runs whose end-effector error ends inside rho_inf and stays there "
        "(the settle-time statistics are over those runs). `sigma_min(J*)`: smallest singular "
        "value of the true model's generalized Jacobian (task rows) over a run, at the rows "
        "kept in signals.parquet; `own sigma`: the one the controller damps (its own matrix, "
        "with its estimates: `min_sigma_of`).",
        "",
    ]
    lines += [f"![{name}]({file})" for name, file in files.items() if name != "rate"]
    return lines


def _overlays(out: Path, runs, by, labels) -> list[str]:
    drawn = overlay_figures(out, runs, by, labels)
    if not drawn:
        return []
    lines = [
        "",
        "## Median and worst runs",
        "",
        "Per controller: the run of median RMS end-effector error (left) and the worst run "
        "(right: the one that left a funnel or stopped first; if all kept their funnels, the "
        "largest RMS error), from `signals.parquet`. Top: each end-effector error component "
        "over its funnel width, e_i / rho_i, with its bounds (dashed); middle: the same for the "
        "base attitude; bottom: each joint torque over its limit (dashed: the limits).",
        "",
    ]
    for title, file, median, worst in drawn:
        lines += [
            f"**{title}**: median case {median['case']}, worst case {worst['case']}.",
            "",
            f"![{title}]({file})",
            "",
        ]
    return lines


def _worst(out: Path, cols, worst) -> list[str]:
    lines = ["", f"## The {N_WORST} worst cases", ""]
    lines += [
        "Funnels not kept first, then by max |u_m|. Each line's command re-runs that case alone "
        "(from this folder: `worst/` holds the case's exact scenario):",
        "",
    ]
    (out / "worst").mkdir(exist_ok=True)
    names = {f"worst/case-{r['case']:05d}.toml" for r in worst}
    for stale in (out / "worst").glob("case-*.toml"):  # an earlier report's worst cases
        if f"worst/{stale.name}" not in names:
            stale.unlink()
    for r in worst:
        name = f"worst/case-{r['case']:05d}.toml"
        (out / name).write_text(r["scenario_toml"], encoding="utf-8")
        r["command"] = f"`python -m ffsm_pin.sim --scenario {name}`"
    lines += table(
        worst,
        [
            ("case", "case", "{}"),
            *((c, c, None) for c in cols),
            ("status", "status", "{}"),
            ("funnels b / z", None, None),
            ("max norm u_m [N m]", "max_abs_u", "{:.4g}"),
            ("min sigma [m]", "min_sigma", "{:.3g}"),
            ("stopped at [s]", "stop_time", "{:.2f}"),
            ("re-run", "command", "{}"),
        ],
        extra={
            "funnels b / z": lambda r: (
                f"{kept_text(r['funnel_ok_b'])} / {kept_text(r['funnel_ok_z'])}"
            )
        },
    )
    stops = [r for r in worst if r["stop_reason"]]
    if stops:
        lines += ["", "Why they stopped:", ""]
        lines += [f"* case {r['case']}: {' '.join(r['stop_reason'].split())}" for r in stops]
    return lines


def _queries(cols, by, have, failed: bool) -> list[str]:
    here = Path("results.parquet")
    texts = [
        sql(RATE_SQL, here, cols),
        sql(SPREAD_SQL, here, cols, extra=extra(SPREAD_EXTRA, have)),
        sql(WORST_SQL, here, cols),
        sql(CAUSES_SQL, here, cols),
    ]
    if CONTROLLER_KEY in cols:
        texts.append(controller_sql(here, by, have))
    if failed:
        texts.append(sql(FAILED_SQL, here, by=by_sel(by)))
    lines = [
        "",
        "## The queries",
        "",
        "Every table above is one DuckDB query over `results.parquet` (run them with "
        '`duckdb -c "..."` or `duckdb.sql(...)` in Python); the exact intervals, the paired '
        "comparison and the run counts are computed from their rows with scipy "
        "(`ffsm_pin/sweep/stats.py`):",
        "",
        "```sql",
    ]
    for text in texts:
        lines += [text, ";", ""]
    return [*lines[:-1], "```", ""]


def _campaign_arg(campaign: Campaign) -> str:
    from ..campaign import BUILTIN_CAMPAIGNS, builtin_campaign_path

    if campaign.name in BUILTIN_CAMPAIGNS and Path(campaign.source) == builtin_campaign_path(
        campaign.name
    ):
        return campaign.name
    return str(Path(campaign.source).resolve())
