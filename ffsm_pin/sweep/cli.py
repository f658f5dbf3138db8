"""``python -m ffsm_pin.sweep``: run a campaign on a Dask cluster (docs/campaigns.md).

Exit status: 0 when every case has a row (runs that stopped early are results); 3 when some
case failed with an error (its row says why); 2 for bad input, a folder another campaign is
running into, or a folder that holds another campaign (one ``error: ...`` line on stderr,
before any case runs, nothing written); 130 when interrupted (finished rows kept).

One campaign at a time writes into a folder: :class:`~ffsm_pin.sweep.folder.FolderLock` is held
from before anything is written there until the report is written.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import logging
import os
import shutil
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .._cli import UsageError, command_parser, fail, positive_int
from .._docstrings import fill_doc
from ..errors import FfsmError
from ._docs import SWEEP_DOC
from .campaign import BUILTIN_CAMPAIGNS, Campaign, load_campaign
from .cases import Case, expand
from .check import check_cases
from .folder import (
    CAMPAIGN_FILE,
    CampaignFolderError,
    CampaignIdentity,
    FolderLock,
    campaign_file_text,
    folder_campaign,
    write_text_atomic,
)

if TYPE_CHECKING:
    from sys import UnraisableHookArgs

EXIT_OK, EXIT_BAD_INPUT, EXIT_ERRORS, EXIT_INTERRUPTED = 0, 2, 3, 130

_EPILOG = f"""\
built-in campaigns: {", ".join(BUILTIN_CAMPAIGNS)}.

output folder (default ./campaigns/<name>-<YYYYmmdd-HHMMSS>/): results.parquet (one row per
case), campaign.toml (the campaign as run), report.md and its figures. Running a campaign into
a folder that holds its results resumes it (finished cases are not run again); one campaign
at a time runs into a folder, and a folder holding another campaign needs --force.
exit status: 0 every case has a row, 3 some case failed with an error, 2 bad input (also: the
folder is in use, or holds another campaign), 130 interrupted."""


def build_parser() -> argparse.ArgumentParser:
    """The command-line parser (docs/campaigns.md)."""
    p = command_parser(
        "ffsm_pin.sweep",
        "Run many variations of a scenario on a Dask cluster; write results.parquet and report.md.",
        _EPILOG,
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
    p.add_argument(
        "--force",
        action="store_true",
        help="run every case again (no resume), also into a folder of another campaign",
    )
    p.add_argument(
        "--keep-runs",
        action="store_true",
        help="keep each case's run folder (runs/case-NNNNN/, as python -m ffsm_pin.sim writes)",
    )
    p.add_argument(
        "--batch-size",
        metavar="N",
        type=positive_int,
        help="most cases a worker runs in one task, cases of one robot and controller "
        "(default: about 4 batches per worker, at most 8 cases each; docs/campaigns.md)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar (stdout: the folder)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    hook = sys.unraisablehook
    sys.unraisablehook = _note_lost_interrupt(hook)
    try:
        return _main(argv)
    finally:
        sys.unraisablehook = hook


_lost_interrupts: list[object] = []


def _note_lost_interrupt(
    hook: Callable[[UnraisableHookArgs], object],
) -> Callable[[UnraisableHookArgs], None]:
    """An unraisable-exception hook that keeps a KeyboardInterrupt for :func:`_main`.

    numba's compiler calls back into Python from C (ctypes); a Ctrl-C that lands there is
    printed as "Exception ignored ..." with a traceback and lost. It is noted instead, and
    the campaign stops as interrupted after its set-up.
    """

    def note(unraisable: UnraisableHookArgs) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            _lost_interrupts.append(unraisable.exc_value)
        else:
            hook(unraisable)

    return note


def _main(argv: Sequence[str] | None) -> int:
    out: Path | None = None
    _lost_interrupts.clear()
    try:
        try:
            args = build_parser().parse_args(argv)
        except UsageError as exc:
            return fail(f"{exc} (see --help)")
        try:
            campaign = load_campaign(args.campaign)
            cases = expand(campaign)
            check_cases(cases, campaign.source)
            if _lost_interrupts:  # a Ctrl-C while numba compiled or loaded the set-up's code
                raise KeyboardInterrupt
            out = _out_dir(args.out, campaign.name)
        except FfsmError as exc:
            return fail(str(exc))
        except OSError as exc:
            return fail(f"cannot create the output folder: {exc}")
        return run(campaign, cases, out, args)
    except KeyboardInterrupt:
        results = None if out is None else out / "results.parquet"
        if results is not None and results.is_file():
            print(f"interrupted; finished rows are in {results}", file=sys.stderr)
        else:
            print("interrupted; no case had finished", file=sys.stderr)
        return EXIT_INTERRUPTED
    except FfsmError as exc:
        return fail(str(exc))
    except OSError as exc:
        name = f" {exc.filename!r}" if exc.filename else ""
        return fail(f"cannot write{name}: {exc.strerror or exc}")


@fill_doc(SWEEP_DOC)
def run(campaign: Campaign, cases: list[Case], out: Path, args: argparse.Namespace) -> int:
    """Resume or start the campaign in ``out``, write the report; the exit status.

    The folder's lock is held throughout (:class:`~ffsm_pin.sweep.folder.FolderLock`).

    Raises
    ------
    FfsmError
        Another campaign runs into ``out`` (:class:`~ffsm_pin.sweep.folder.FolderInUseError`),
        or ``out`` holds another campaign's ``campaign.toml`` and ``args.force`` is not set.

    Parameters
    ----------
    %(campaign_cases)s
    out : Path
        The campaign folder.
    args : argparse.Namespace
        The command line.

    Returns
    -------
    int
        The exit status.
    """
    with FolderLock(out, campaign.name) as lock:
        if lock.stale is not None:
            _warn(
                args,
                f"took over {out / lock.path.name} of {lock.stale.text()}, whose process no "
                "longer holds it (killed?); its finished rows are kept",
            )
        if lock.unsupported is not None:
            _warn(args, f"cannot lock {lock.unsupported}; running unlocked")
        return _run_locked(campaign, cases, out, args)


def _run_locked(campaign: Campaign, cases: list[Case], out: Path, args: argparse.Namespace) -> int:
    from .auto_repeat import grow, resumed
    from .report import write_report
    from .table import ResultsTable

    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    _check_same_campaign(campaign, out, args, stamp)
    write_text_atomic(
        out / CAMPAIGN_FILE, campaign_file_text(campaign.name, campaign.source, campaign.text)
    )
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


def _check_same_campaign(
    campaign: Campaign, out: Path, args: argparse.Namespace, stamp: str
) -> None:
    """Refuse a folder whose campaign.toml is another campaign's (name or scenarios differ);
    with --force, keep that campaign's files under new names and go on."""
    held = out / CAMPAIGN_FILE
    if held.is_file() and held.resolve() == Path(campaign.source).resolve():
        return  # the campaign file given is the folder's own copy
    try:
        theirs = folder_campaign(out)
        problem = None
    except CampaignFolderError as exc:
        theirs, problem = None, str(exc)
    ours = CampaignIdentity(campaign.name, tuple(campaign.scenarios))
    if problem is None and (theirs is None or theirs.same_as(ours)):
        return
    what = problem or f"{held} is campaign {theirs.text() if theirs else ''}"
    if not args.force:
        raise CampaignFolderError(
            f"--out {str(out)!r} holds another campaign: {what}, not {ours.text()}; resume it "
            "with its own campaign file, choose another --out, or use --force to run this "
            "campaign there (the other one's files are kept under new names)"
        )
    kept = []
    for name, new in (
        (CAMPAIGN_FILE, f"campaign-before-{stamp}.toml"),
        ("results.parquet", f"results-before-{stamp}.parquet"),
        ("signals.parquet", f"signals-before-{stamp}.parquet"),
    ):
        if (out / name).is_file():
            os.replace(out / name, out / new)
            kept.append(new)
    _warn(args, f"{what}, not {ours.text()} (--force): its files are kept as {', '.join(kept)}")


def _run_on_cluster(todo, table, out: Path, args, name: str, total: int) -> None:
    from tqdm import tqdm

    from .engine import run_cases, shutdown, start_client

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
        for case, outcome in run_cases(client, todo, keep, batch_size=args.batch_size):
            table.add(case, outcome, write=table.write_due())
            if outcome["status"] in counts:
                counts[outcome["status"]] += 1
            bar.set_postfix_str(f"stopped {counts['stopped']}, failed {counts['error']}")
            bar.update(1)
    finally:  # also on Ctrl-C: every finished row reaches the file, Dask stops quietly
        try:
            table.flush()
            bar.close()
        finally:
            shutdown(client, cluster)


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
    while True:  # made here, so that two campaigns started in the same second get two folders
        try:
            path.mkdir(parents=True)
            return path
        except FileExistsError:
            k += 1
            path = base.with_name(f"{base.name}-{k}")


def _warn(args, message: str) -> None:
    if not args.quiet:
        print(f"warning: {message}", file=sys.stderr)
