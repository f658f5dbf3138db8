"""``python -m ffsm_pin.sweep``: run a campaign on a Dask cluster (docs/campaigns.md).

Exit status: 0 when every case has a row (runs that stopped early are results); 3 when some
case failed with an error (its row says why); 2 for bad input (one ``error: ...`` line on
stderr, before any case runs, nothing written); 130 when interrupted (finished rows kept).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import logging
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from .._cli import Parser, UsageError, fail, positive_int
from ..errors import FfsmError
from .campaign import BUILTIN_CAMPAIGNS, Campaign, Case, check_cases, expand, load_campaign

EXIT_OK, EXIT_BAD_INPUT, EXIT_ERRORS, EXIT_INTERRUPTED = 0, 2, 3, 130

_EPILOG = f"""\
built-in campaigns: {", ".join(BUILTIN_CAMPAIGNS)}.

output folder (default ./campaigns/<name>-<YYYYmmdd-HHMMSS>/): results.parquet (one row per
case), campaign.toml (the campaign as run), report.md and its figures. Running a campaign into
a folder that holds its results resumes it (finished cases are not run again).
exit status: 0 every case has a row, 3 some case failed with an error, 2 bad input,
130 interrupted."""


def build_parser() -> argparse.ArgumentParser:
    """The command-line parser (docs/campaigns.md)."""
    p = Parser(
        prog="python -m ffsm_pin.sweep",
        description="Run many variations of a scenario on a Dask cluster; write "
        "results.parquet and report.md.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("campaign", metavar="CAMPAIGN", help="campaign file (TOML) or built-in name")
    p.add_argument("--out", metavar="DIR", help="output folder (an existing one is resumed)")
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        metavar="N",
        type=positive_int,
        help="local worker processes, one thread each (default: number of cores)",
    )
    where.add_argument(
        "--scheduler", metavar="ADDRESS", help="use the running Dask cluster at tcp://host:port"
    )
    p.add_argument("--force", action="store_true", help="run every case again (no resume)")
    p.add_argument(
        "--keep-runs",
        action="store_true",
        help="keep each case's run folder (runs/case-NNNNN/, as python -m ffsm_pin.sim writes)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar (stdout: the folder)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
    except UsageError as exc:
        return fail(f"{exc} (see --help)")
    try:
        campaign = load_campaign(args.campaign)
        cases = expand(campaign)
        check_cases(cases, campaign.source)
        out = _out_dir(args.out, campaign.name)
    except FfsmError as exc:
        return fail(str(exc))
    except OSError as exc:
        return fail(f"cannot create the output folder: {exc}")
    try:
        return run(campaign, cases, out, args)
    except KeyboardInterrupt:
        print(f"interrupted; finished rows are in {out / 'results.parquet'}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:
        name = f" {exc.filename!r}" if exc.filename else ""
        return fail(f"cannot write{name}: {exc.strerror or exc}")


def run(campaign: Campaign, cases: list[Case], out: Path, args: argparse.Namespace) -> int:
    """Resume or start the campaign in ``out``, write the report; the exit status."""
    from .auto_repeat import grow, resumed
    from .report import write_report
    from .table import ResultsTable

    out.mkdir(parents=True, exist_ok=True)
    (out / "campaign.toml").write_text(campaign.text, encoding="utf-8")
    table = ResultsTable(out / "results.parquet", campaign.columns)
    campaign, cases = resumed(campaign, cases, table.read())  # repeat = "auto"
    by_hash = {c.case_hash: c for c in cases}
    stale = 0
    if not args.force:
        for row in table.read():
            case = by_hash.get(str(row.get("case_hash")))
            if case is not None and row.get("status") in ("completed", "stopped"):
                table.keep(row, case)
            elif case is None:
                stale += 1
    if stale:  # keep the old file: those rows are not this campaign's, but they are results
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        old = out / f"results-before-{stamp}.parquet"
        shutil.copy2(table.path, old)
        _warn(
            args,
            f"{stale} rows of results.parquet are not cases of this campaign (another version "
            f"of it?); they are left out, the previous file is kept as {old.name}",
        )
    todo = [c for c in cases if c.case_hash not in table.rows]
    table.write()
    ran = 0
    batch: tuple[Campaign, list[Case], list[Case]] | None = (campaign, cases, todo)
    while batch is not None:  # repeat = "auto": batches until the target is met or capped
        campaign, cases, todo = batch
        if todo:
            _run_on_cluster(todo, table, out, args, campaign.name, len(cases))
        ran += len(todo)
        batch = grow(campaign, table)
    write_report(out, campaign)
    n_err = sum(r["status"] == "error" for r in table.rows.values())
    n_stop = sum(r["status"] == "stopped" for r in table.rows.values())
    if args.quiet:
        print(out)
    else:
        print(
            f"{campaign.name}: {len(table.rows)} cases ({ran} run now), {n_stop} stopped "
            f"early, {n_err} errors\nresults: {out / 'results.parquet'}\nreport:  "
            f"{out / 'report.md'}"
        )
    return EXIT_ERRORS if n_err else EXIT_OK


def _run_on_cluster(todo, table, out: Path, args, name: str, total: int) -> None:
    from tqdm import tqdm

    from .engine import run_cases, start_client

    for logger in ("distributed", "tornado", "bokeh"):
        logging.getLogger(logger).setLevel(logging.CRITICAL if args.quiet else logging.ERROR)
    client, cluster = start_client(args.workers, args.scheduler, quiet=args.quiet)
    keep = out / "runs" if args.keep_runs else None
    counts = {"stopped": 0, "error": 0}
    bar = tqdm(
        total=len(todo),
        desc=f"{name} ({total - len(todo)} of {total} done before)" if len(todo) < total else name,
        unit="case",
        file=sys.stderr,
        disable=args.quiet,
        dynamic_ncols=True,
        smoothing=0.1,
    )
    try:
        bar.set_postfix_str("stopped 0, failed 0")
        for case, outcome in run_cases(client, todo, keep):
            table.add(case, outcome, write=table.write_due())
            if outcome["status"] in counts:
                counts[outcome["status"]] += 1
            bar.set_postfix_str(f"stopped {counts['stopped']}, failed {counts['error']}")
            bar.update(1)
    finally:  # also on Ctrl-C: every finished row reaches the file
        table.flush()
        bar.close()
        client.close()
        if cluster is not None:
            cluster.close()


def _out_dir(out: str | None, name: str) -> Path:
    if out is not None:
        path = Path(out)
        if path.exists() and not path.is_dir():
            raise FfsmError(f"--out {out!r} is a file, not a folder")
        return path
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "campaign"
    base = Path("campaigns") / f"{safe}-{stamp}"
    path, k = base, 1
    while path.exists():
        k += 1
        path = base.with_name(f"{base.name}-{k}")
    return path


def _warn(args, message: str) -> None:
    if not args.quiet:
        print(f"warning: {message}", file=sys.stderr)
