"""report.md of a campaign: DuckDB SQL over results.parquet, matplotlib figures.

The queries are plain SQL on the Parquet file (:data:`RATE_SQL`, :data:`SPREAD_SQL`,
:data:`WORST_SQL`; ``{cols}`` is the list of varied keys as quoted identifiers, ``{path}``
the file); report.md prints them, so a reader can run the same ones in ``duckdb``.

A case *keeps its funnels* when it completed the whole horizon with both funnels kept
(``status = 'completed' AND funnel_ok_b AND funnel_ok_z``); rows with ``status = 'error'`` are
not runs and are left out of the rates (and listed). Rates carry 95 % Wilson score intervals.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import duckdb

from .campaign import SCENARIO_COLUMN, Campaign

__all__ = [
    "CAUSES_SQL", "CONTROLLER_SQL", "RATE_SQL", "SPREAD_SQL", "WORST_SQL", "controller_table",
    "query", "write_report",
]  # fmt: skip

Z95 = 1.959963984540054  # standard normal quantile of 0.975
N_WORST = 10

KEPT = "(status = 'completed' AND funnel_ok_b AND funnel_ok_z)"


def _wilson(rate: str, n: str, name: str) -> str:
    """SQL for the 95 % Wilson score interval of the column ``rate`` (a share of ``n`` runs),
    as ``name_lo`` and ``name_hi``."""
    half = f"{Z95} * sqrt({rate} * (1 - {rate}) / {n} + {Z95}^2 / (4 * {n} * {n}))"
    centre, scale = f"{rate} + {Z95}^2 / (2 * {n})", f"(1 + {Z95}^2 / {n})"
    return (
        f"({centre} - {half})\n    / {scale} AS {name}_lo,\n"
        f"  ({centre} + {half})\n    / {scale} AS {name}_hi"
    )


RATE_SQL = f"""\
WITH counts AS (
  SELECT {{cols_sel}}
         count(*) FILTER (WHERE status <> 'error') AS n,
         count(*) FILTER (WHERE {KEPT}) AS kept,
         count(*) FILTER (WHERE status = 'stopped') AS stopped,
         count(*) FILTER (WHERE status = 'error') AS errors
  FROM read_parquet('{{path}}')
  WHERE NOT nominal
  {{group}}
), rates AS (
  SELECT *, CASE WHEN n > 0 THEN kept / n END AS rate FROM counts
)
SELECT *,  -- Wilson score interval, z = {Z95:.4f}
  {_wilson("rate", "n", "rate")}
FROM rates
{{order}}"""

SPREAD_SQL = """\
SELECT {cols_sel}
  median(max_abs_u) AS u_median,
  quantile_cont(max_abs_u, 0.95) AS u_p95,
  max(max_abs_u) AS u_max,
  count(settle_time_z) AS settled_z,
  median(settle_time_z) AS settle_z_median,
  max(settle_time_z) AS settle_z_max,
  median(settle_time_b) AS settle_b_median,
  min(min_sigma) AS sigma_min,
  median(min_sigma) AS sigma_median
FROM read_parquet('{path}')
WHERE NOT nominal AND status <> 'error'
{group}
{order}"""

WORST_SQL = f"""\
SELECT "case", {{cols_sel}}estimates_seed, status, funnel_ok_b, funnel_ok_z, max_abs_u,
       min_sigma, stop_time, stop_reason, scenario_toml
FROM read_parquet('{{path}}')
WHERE NOT nominal AND status <> 'error'
ORDER BY {KEPT} ASC, max_abs_u DESC NULLS FIRST
LIMIT {N_WORST}"""

CAUSES_SQL = """\
SELECT {cols_sel}
  CASE
    WHEN stop_reason ILIKE '%left its funnel%' THEN 'funnel left'
    WHEN stop_reason ILIKE '%singular%' THEN 'arm or filter singular'
    WHEN stop_reason ILIKE '%blow-up%' OR stop_reason ILIKE '%non-finite%'
      THEN 'numerical blow-up'
    WHEN stop_reason ILIKE '%positive definite%' OR stop_reason ILIKE '%collapsed%'
      THEN 'estimate degenerate'
    ELSE 'other'
  END AS cause,
  count(*) AS runs,
  min(stop_time) AS first_stop,
  median(stop_time) AS median_stop
FROM read_parquet('{path}')
WHERE NOT nominal AND status = 'stopped'
GROUP BY ALL
ORDER BY ALL"""

CONTROLLER_KEY = "controller.type"
KEPT_Z = "(status = 'completed' AND funnel_ok_z)"


CONTROLLER_SQL = f"""\
WITH runs AS (
  SELECT * FROM read_parquet('{{path}}') WHERE NOT nominal AND status <> 'error'
), per AS (
  SELECT {{by}}"{CONTROLLER_KEY}" AS controller,
         count(*) AS n,
         count(*) FILTER (WHERE {KEPT}) AS kept,
         count(*) FILTER (WHERE {KEPT_Z}) AS kept_z,
         median(rms_err_z_late) AS rms_err_z_late,
         median(max_abs_u) AS max_abs_u,
         median(saturation_fraction) AS saturation_fraction,
         median(control_effort) AS control_effort,
         median(max_base_excursion) AS max_base_excursion,
         count(settle_time_z) AS settled_z,
         median(settle_time_z) AS settle_time_z
  FROM runs
  GROUP BY ALL
), rates AS (
  SELECT *, kept / n AS rate, kept_z / n AS rate_z FROM per
)
SELECT *,  -- Wilson score intervals, z = {Z95:.4f}
  {_wilson("rate", "n", "rate")},
  {_wilson("rate_z", "n", "rate_z")}
FROM rates
ORDER BY {{by}}controller"""

POINTS_SQL = """\
SELECT {cols_sel} max_abs_u, settle_time_z, min_sigma, damping_threshold
FROM read_parquet('{path}')
WHERE NOT nominal AND status <> 'error'
{order}"""


def _sql(template: str, path: Path, cols: list[str]) -> str:
    quoted = [_ident(c) for c in cols]
    text = template.format(
        path=str(path).replace("'", "''"),
        cols_sel="".join(f"{c}, " for c in quoted),
        group=f"GROUP BY {', '.join(quoted)}" if cols else "",
        order=f"ORDER BY {', '.join(quoted)}" if cols else "",
    )
    return "\n".join(line.rstrip() for line in text.splitlines() if line.strip())


def _ident(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def query(sql: str) -> list[dict[str, Any]]:
    """Run SQL in a fresh in-memory DuckDB; rows as dicts."""
    con = duckdb.connect()
    try:
        cur = con.execute(sql)
        names = [d[0] for d in cur.description]
        return [dict(zip(names, row, strict=True)) for row in cur.fetchall()]
    finally:
        con.close()


def controller_table(path: Path, by: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """The per-controller rows of :data:`CONTROLLER_SQL` for ``results.parquet`` at ``path``,
    per value of the columns ``by`` too (``("scenario",)``: per scenario and controller)."""
    return query(CONTROLLER_SQL.format(path=str(path).replace("'", "''"), by=_by_sel(by)))


def _by_sel(by: tuple[str, ...]) -> str:
    return "".join(f"{_ident(c)}, " for c in by)


def _controller_section(path: Path, by: tuple[str, ...] = ()) -> list[str]:
    """report.md's per-controller table (campaigns that vary controller.type)."""
    rows = controller_table(path, by)
    lines = [
        "## Per controller" + (" and scenario" if by else ""),
        "",
        "Over every grid point of each controller (medians over its runs; rates with 95 % "
        "Wilson intervals). `kept b+z`: the whole horizon with both funnels kept; `kept z`: "
        "with the end-effector funnel kept (a controller that leaves the base attitude free, "
        "as gjm-ct, is judged on this one). RMS e_z: over the last half of each run; effort: "
        "integral of |u_m|^2 dt; excursion: largest base rotation from its initial attitude.",
        "",
    ]
    lines += _table(
        rows,
        [
            *((c, c, "{}") for c in by),
            ("controller", "controller", "{}"),
            ("runs", "n", "{}"),
            ("kept b+z", None, None),
            ("kept z", None, None),
            ("RMS e_z", "rms_err_z_late", "{:.3g}"),
            ("max abs u_m [N m]", "max_abs_u", "{:.4g}"),
            ("saturated", "saturation_fraction", "{:.1%}"),
            ("effort [N^2 m^2 s]", "control_effort", "{:.4g}"),
            ("excursion [rad]", "max_base_excursion", "{:.3g}"),
            ("settled z", "settled_z", "{}"),
            ("settle z [s]", "settle_time_z", "{:.2f}"),
        ],
        extra={
            "kept b+z": lambda r: (
                f"{_f(r['rate'], '{:.0%}')} ({_f(r['rate_lo'], '{:.0%}')} - "
                f"{_f(r['rate_hi'], '{:.0%}')})"
            ),
            "kept z": lambda r: (
                f"{_f(r['rate_z'], '{:.0%}')} ({_f(r['rate_z_lo'], '{:.0%}')} - "
                f"{_f(r['rate_z_hi'], '{:.0%}')})"
            ),
        },  # fmt: skip
    )
    return lines + [""]


def _scenarios_text(campaign: Campaign) -> str:
    if len(campaign.scenarios) == 1:
        return f"Scenario `{campaign.scenario}`"
    return "Scenarios " + ", ".join(f"`{x}`" for x in campaign.scenarios)


def _nominal_text(campaign: Campaign) -> str:
    if len(campaign.scenarios) == 1:
        return "case 0 is the nominal scenario"
    return "the first case of each scenario is its nominal run"


def write_report(out: Path, campaign: Campaign) -> Path:
    """Write ``report.md``, its figures (``fig_*.png``) and the worst cases' scenario files
    (``worst/case-NNNNN.toml``) into ``out``; return the report's path."""
    path = out / "results.parquet"
    cols = list(campaign.axes)
    by = tuple(c for c in cols if c == SCENARIO_COLUMN)
    rates = query(_sql(RATE_SQL, path, cols))
    spread = query(_sql(SPREAD_SQL, path, cols))
    worst = query(_sql(WORST_SQL, path, cols))
    points = query(_sql(POINTS_SQL, path, cols))
    causes = query(_sql(CAUSES_SQL, path, cols))
    nominal = query(f"SELECT * FROM read_parquet('{path}') WHERE nominal ORDER BY \"case\"")
    errors = query(
        f"SELECT \"case\", error FROM read_parquet('{path}') WHERE status = 'error' ORDER BY 1"
    )
    total = query(f"SELECT count(*) AS n, sum(wall_time_s) AS wall FROM read_parquet('{path}')")[0]
    figures = _figures(out, cols, rates, points)

    lines = [f"# Campaign `{campaign.name}`", ""]
    if campaign.description:
        lines += [campaign.description, ""]
    lines += [
        f"{_scenarios_text(campaign)}, root seed {campaign.seed}, {campaign.repeat} draws per "
        f"grid point, {campaign.n_cases} cases ({_nominal_text(campaign)}); "
        f"{total['n']} rows in `results.parquet`, {_f(total['wall'], '{:.0f}')} s of simulation "
        "wall time in total.",
        "",
        "Reproduce (from the repository root; an existing folder is resumed, `--force` re-runs):",
        "",
        "```bash",
        f"python -m ffsm_pin.sweep {_campaign_arg(campaign)} --out {out}",
        "```",
        "",
        "A case **keeps its funnels** when it runs the whole horizon with both funnels kept "
        f"(`{KEPT}`). Runs that stop early (funnel left, arm singular too long, blow-up) count "
        "as not kept; rows with `status = 'error'` are not runs and are left out of the rates.",
        "",
    ]
    if nominal:
        lines += ["## Nominal case" + ("s" if len(nominal) > 1 else ""), ""]
        for r in nominal:
            which = f"the scenario `{r['scenario']}`" if by else "the scenario"
            lines += [
                f"Case {r['case']}, {which} as shipped: status `{r['status']}`, funnels "
                f"{_kept(r.get('funnel_ok_b'))} / {_kept(r.get('funnel_ok_z'))} (b / z), max "
                f"|u_m| = {_f(r.get('max_abs_u'), '{:.4g}')} N m, settle time z = "
                f"{_f(r.get('settle_time_z'), '{:.2f}')} s, min sigma = "
                f"{_f(r.get('min_sigma'), '{:.3g}')} m.",
                "",
            ]
    if CONTROLLER_KEY in cols:
        lines += _controller_section(path, by)
    lines += ["## Funnel-keeping rate per grid point (95 % Wilson interval)", ""]
    lines += _table(
        rates,
        [
            *((c, c, None) for c in cols),
            ("runs", "n", "{}"),
            ("kept", "kept", "{}"),
            ("rate", "rate", "{:.0%}"),
            ("95 % interval", None, None),
            ("stopped early", "stopped", "{}"),
            ("errors", "errors", "{}"),
        ],
        extra={
            "95 % interval": lambda r: (
                f"{_f(r['rate_lo'], '{:.0%}')} - {_f(r['rate_hi'], '{:.0%}')}"
            )
        },  # fmt: skip
    )
    lines += ["", f"![funnel-keeping rate]({figures['rate']})", ""]
    if causes:
        lines += ["Why runs stopped early (from `stop_reason`):", ""]
        lines += _table(
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
    lines += ["## Control effort, settling and distance to singularity per grid point", ""]
    lines += _table(
        spread,
        [
            *((c, c, None) for c in cols),
            ("max abs u_m: median [N m]", "u_median", "{:.4g}"),
            ("95th pct", "u_p95", "{:.4g}"),
            ("max", "u_max", "{:.4g}"),
            ("settled z", "settled_z", "{}"),
            ("settle z median [s]", "settle_z_median", "{:.2f}"),
            ("settle z max [s]", "settle_z_max", "{:.2f}"),
            ("settle b median [s]", "settle_b_median", "{:.2f}"),
            ("min sigma [m]", "sigma_min", "{:.3g}"),
            ("median min sigma [m]", "sigma_median", "{:.3g}"),
        ],
    )
    lines += [
        "",
        "`settled z`: runs whose end-effector error ends inside rho_inf and stays there "
        "(the settle-time statistics are over those runs). `min sigma`: smallest singular value "
        "of the arm's task Jacobian over a run (damped least squares below the threshold).",
        "",
    ]
    lines += [f"![{name}]({file})" for name, file in figures.items() if name != "rate"]
    lines += ["", f"## The {N_WORST} worst cases", ""]
    lines += [
        "Funnels not kept first, then by max |u_m|. Each line's command re-runs that case alone "
        "(from this folder: `worst/` holds the case's exact scenario):",
        "",
    ]
    (out / "worst").mkdir(exist_ok=True)
    for r in worst:
        name = f"worst/case-{r['case']:05d}.toml"
        (out / name).write_text(r["scenario_toml"], encoding="utf-8")
        r["command"] = f"`python -m ffsm_pin.sim --scenario {name}`"
    lines += _table(
        worst,
        [
            ("case", "case", "{}"),
            *((c, c, None) for c in cols),
            ("status", "status", "{}"),
            ("funnels b / z", None, None),
            ("max abs u_m [N m]", "max_abs_u", "{:.4g}"),
            ("min sigma [m]", "min_sigma", "{:.3g}"),
            ("stopped at [s]", "stop_time", "{:.2f}"),
            ("re-run", "command", "{}"),
        ],
        extra={"funnels b / z": lambda r: f"{_kept(r['funnel_ok_b'])} / {_kept(r['funnel_ok_z'])}"},
    )
    stops = [r for r in worst if r["stop_reason"]]
    if stops:
        lines += ["", "Why they stopped:", ""]
        lines += [f"* case {r['case']}: {' '.join(r['stop_reason'].split())}" for r in stops]
    if errors:
        lines += ["", "## Cases that failed with an error", ""]
        lines += [f"* case {r['case']}: {r['error']}" for r in errors]
    lines += [
        "",
        "## The queries",
        "",
        "Every table above is one DuckDB query over `results.parquet` (run them with "
        '`duckdb -c "..."` or `duckdb.sql(...)` in Python):',
        "",
        "```sql",
        _sql(RATE_SQL, Path("results.parquet"), cols),
        ";",
        "",
        _sql(SPREAD_SQL, Path("results.parquet"), cols),
        ";",
        "",
        _sql(WORST_SQL, Path("results.parquet"), cols),
        ";",
        "",
        _sql(CAUSES_SQL, Path("results.parquet"), cols),
        ";",
        *(
            ["", CONTROLLER_SQL.format(path="results.parquet", by=_by_sel(by)), ";"]
            if CONTROLLER_KEY in cols
            else []
        ),
        "```",
        "",
    ]
    report = out / "report.md"
    report.write_text("\n".join(lines), encoding="utf-8")
    return report


# ------------------------------------------------------------------------------ figures
def _figures(out: Path, cols, rates, points) -> dict[str, str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [_label(r, cols) for r in rates]
    numeric = len(cols) == 1 and all(_is_number(r[cols[0]]) for r in rates)
    xs = [float(r[cols[0]]) for r in rates] if numeric else list(range(len(rates)))
    files = {}

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    ok = [i for i, r in enumerate(rates) if r["rate"] is not None]
    ax.errorbar(
        [xs[i] for i in ok],
        [rates[i]["rate"] * 100 for i in ok],
        yerr=[  # >= 0: at a rate of 0 or 1 the bound equals the rate up to rounding
            [max(rates[i]["rate"] - rates[i]["rate_lo"], 0.0) * 100 for i in ok],
            [max(rates[i]["rate_hi"] - rates[i]["rate"], 0.0) * 100 for i in ok],
        ],
        fmt="o-",
        capsize=4,
    )
    ax.set_ylim(-5, 105)
    ax.set_ylabel("funnels kept [% of runs]")
    _xaxis(ax, cols, numeric, xs, labels)
    ax.set_title("funnel-keeping rate, 95 % Wilson intervals")
    ax.grid(alpha=0.3)
    files["rate"] = _save(fig, out / "fig_funnel_rate.png")

    groups: dict[str, list[dict[str, Any]]] = {lab: [] for lab in labels}
    for p in points:
        groups.setdefault(_label(p, cols), []).append(p)
    for key, name, ylabel, log in (
        ("max_abs_u", "max_u", "max |u_m| over a run [N m]", True),
        ("settle_time_z", "settle", "settle time of err_z [s]", False),
        ("min_sigma", "min_sigma", "min sigma over a run [m]", False),
    ):
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        data = [[p[key] for p in groups[lab] if p[key] is not None] for lab in labels]
        pos = [x for x, d in zip(xs, data, strict=True) if d]
        width = 0.6 * (min(_gaps(xs)) if numeric and len(xs) > 1 else 1.0)
        if pos:
            ax.boxplot([d for d in data if d], positions=pos, widths=width, manage_ticks=False)
        if log and any(v > 0 for d in data for v in d):
            ax.set_yscale("log")
        if key == "min_sigma":
            thr = [p["damping_threshold"] for p in points if p["damping_threshold"] is not None]
            if thr:
                ax.axhline(thr[0], color="C3", ls="--", lw=1, label="damping threshold")
                ax.legend(loc="best")
        ax.set_ylabel(ylabel)
        _xaxis(ax, cols, numeric, xs, labels)
        ax.grid(alpha=0.3)
        files[name] = _save(fig, out / f"fig_{name}.png")
    return files


def _xaxis(ax, cols, numeric, xs, labels) -> None:
    if numeric:
        ax.set_xlabel(cols[0])
        ax.set_xticks(xs)
    else:
        ax.set_xticks(xs)
        ax.set_xticklabels(labels, rotation=20 if len(xs) > 3 else 0, ha="right" if len(xs) > 3
                           else "center", fontsize=8)  # fmt: skip
        ax.set_xlabel(" x ".join(cols) if cols else "")


def _save(fig, path: Path) -> str:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path.name


def _gaps(xs):
    s = sorted(xs)
    return [b - a for a, b in zip(s, s[1:], strict=False) if b > a] or [1.0]


# ------------------------------------------------------------------------------ text
def _table(rows, columns, extra=None) -> list[str]:
    extra = extra or {}
    head = [name for name, _, _ in columns]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = []
        for name, key, fmt in columns:
            if name in extra:
                cells.append(extra[name](r))
            elif fmt is None:
                cells.append(_value(r[key]))
            else:
                cells.append(_f(r[key], fmt))
        out.append("| " + " | ".join(cells) + " |")
    return out


def _label(r, cols) -> str:
    return ", ".join(_value(r[c]) for c in cols) or "all"


def _value(v) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return str(v)


def _f(x, fmt: str) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return fmt.format(x)


def _kept(ok) -> str:
    return "-" if ok is None else "kept" if ok else "LEFT"


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _campaign_arg(campaign: Campaign) -> str:
    from .campaign import BUILTIN_CAMPAIGNS, builtin_campaign_path

    if campaign.name in BUILTIN_CAMPAIGNS and Path(campaign.source) == builtin_campaign_path(
        campaign.name
    ):
        return campaign.name
    return campaign.source
