"""``python -m ffsm_pin.sim``: run a scenario, record it, draw it, replay it (docs/cli.md).

Exit status: 0 when every run completed; 3 when a run stopped early (everything recorded is
still written, and one line on stderr says when and why) or was recovered (``--recover``); 2
for bad input (one line ``error: ...`` on stderr, never a traceback); 4 when a file could not
be written (one ``error:`` line naming it; the folder keeps the earlier run); 130 when
interrupted. docs/cli.md, "What is kept when something fails".
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import signal
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

from .._cli import UsageError, command_parser, fail, positive_float, positive_int
from ..errors import FfsmError, OutputError, ScenarioError
from ..scenario.file import BUILTIN, builtin_scenario, load_scenario
from ..scenario.spec import Scenario
from .compile_note import note_compilation
from .console import Console, result_table, stop_line
from .files import RunFolder, check_writable, output_error
from .outputs import write_outputs
from .result import FIGURE_ROWS, RunResult

EXIT_OK, EXIT_BAD_INPUT, EXIT_STOPPED, EXIT_OUTPUT, EXIT_INTERRUPTED = 0, 2, 3, 4, 130
# figures and replay.html of a longer run are drawn from this many evenly spaced rows
PLOT_ROWS = FIGURE_ROWS
COMPARE_CASES = ("case1", "case2", "case3")
# --compare [SET]: the paper's planar cases 1-3, or their spatial counterparts
COMPARE_SETS = {
    "planar": COMPARE_CASES,
    "spatial": ("spatial", "spatial-no-ppc", "spatial-no-attitude"),
}
_CASE_ALIASES = {"1": "case1", "2": "case2", "3": "case3", "1-paper": "case1-paper"}

_EPILOG = """\
cases (--case): 1 = adaptive coordinated control with prescribed performance (the paper's case
1, with rho_b0 = 1.0: see the comment in the scenario file), 1-paper = case 1 with the paper's
exact rho_b0 = 0.4, 2 = without prescribed performance, 3 = without base attitude regulation
(Eq. 81), known-model = case 1 with the true parameters, planar5 = a 5-link robot with one
spare joint and 30 % parameter error (null-space option: docs/null_space.md).
spatial = a 7-joint arm (Panda) on a satellite, end-effector position tracking with MRP base
attitude regulation (docs/spatial.md); spatial-known-model, spatial-no-ppc and
spatial-no-attitude are its variants (--compare spatial runs spatial, -no-ppc, -no-attitude).

output folder: trajectory.npz, summary.json, scenario.toml (the scenario as run),
fig_*.png, replay.html (open it in a browser; no server needed).
--recover DIR: what a killed run left in DIR (its spool) becomes trajectory.npz and
summary.json (completed: false).
exit status: 0 completed, 3 stopped early or recovered (outputs still written), 2 bad input,
4 a file could not be written (the folder keeps the earlier run), 130 interrupted."""


def build_parser() -> argparse.ArgumentParser:
    """The command-line parser (options of docs/cli.md)."""
    p = command_parser(
        "ffsm_pin.sim",
        "Simulate a free-floating space manipulator under the adaptive "
        "prescribed-performance coordinated controller of Lu & Jia (2019).",
        _EPILOG,
    )
    what = p.add_mutually_exclusive_group()
    what.add_argument(
        "--case",
        metavar="CASE",
        type=_case_name,
        help=f"built-in case: {_case_choices()} (default: 1)",
    )
    what.add_argument(
        "--compare",
        nargs="*",
        default=None,
        metavar="WHAT",
        help="run several scenarios and overlay their figures; each WHAT is a set ('planar': "
        "cases 1, 2 and 3, the default; 'spatial': spatial, spatial-no-ppc, "
        "spatial-no-attitude), a built-in case or a scenario file",
    )
    what.add_argument("--scenario", metavar="FILE.toml", help="run a scenario file")
    p.add_argument(
        "--controllers",
        metavar="A,B,...",
        type=_controller_list,
        help="run each scenario once per controller type (built-in names, 'file.py:Class' "
        "relative to the current folder, 'package.module:Class') and overlay them",
    )
    what.add_argument(
        "--recover",
        metavar="DIR",
        help="write trajectory.npz and summary.json (completed: false) from what a killed run "
        "left in its output folder DIR (its spool)",
    )
    p.add_argument("--duration", metavar="S", type=positive_float, help="simulated time [s]")
    p.add_argument("--dt", metavar="S", type=positive_float, help="time step [s]")
    p.add_argument(
        "--out", metavar="DIR", help="output folder (default: ./runs/<YYYYmmdd-HHMMSS>/)"
    )
    p.add_argument(
        "--record-every",
        metavar="N",
        type=positive_int,
        default=1,
        help="record every N-th step (default 1: every step)",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="dry run: build the run, print what decides whether it can work, simulate nothing "
        "(exit 2 with one error: line per reason)",
    )
    p.add_argument("--no-plots", action="store_true", help="do not draw the figures")
    p.add_argument("--no-html", action="store_true", help="do not write replay.html")
    p.add_argument(
        "--meshcat",
        action="store_true",
        help="afterwards, replay the run on a live meshcat server (prints the URL; Ctrl-C stops)",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress bar, no warnings, no result table (stdout: only the output folder)",
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
    except UsageError as exc:
        return fail(f"{exc} (see --help)")
    console = Console(quiet=args.quiet)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore" if args.quiet else "default")
        for category in (DeprecationWarning, PendingDeprecationWarning):  # not for CLI users
            warnings.simplefilter("ignore", category)
        warnings.showwarning = console.show_warning
        try:
            return _recover(args, console) if args.recover else _run(args, console)
        except OutputError as exc:
            console.clear()
            fail(str(exc))
            return EXIT_OUTPUT
        except FfsmError as exc:
            console.clear()
            return fail(str(exc))
        except OSError as exc:
            console.clear()
            fail(str(output_error(exc, Path(args.out or "."))))
            return EXIT_OUTPUT
        except KeyboardInterrupt:
            console.clear()
            print("interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED


# ------------------------------------------------------------------------------ the runs
def _run(args: argparse.Namespace, console: Console) -> int:
    from .loop import simulate
    from .recording import recording_size  # heavy imports: command line is fine
    from .setup import prepare
    from .storage import check_storage

    scenarios = [_override(sc, args) for sc in _scenarios(args)]
    if args.check:  # compiles no controller (ffsm_pin.control.compiled.no_warm_up)
        return _check(scenarios)
    setups = []
    for sc in scenarios:  # every bad input before any simulation
        console.context = sc.name if len(scenarios) > 1 else ""
        # the compiling note comes once every check but the controller's has passed
        setups.append(prepare(sc, before_controller=lambda: note_compilation(args.quiet)))
        # disk for the recording (spooled rows and trajectory.npz), before any folder is made
        # or anything simulated
        size = recording_size(setups[-1])
        check_storage(*size, args.record_every, args.out or "runs", copies=2)
    root = _out_dir(args.out)
    compare = len(setups) > 1
    folders = [check_writable(root / _safe(su.scenario.name) if compare else root) for su in setups]
    results: list[RunResult] = []
    for setup, folder in zip(setups, folders, strict=True):
        sc = setup.scenario
        console.context = sc.name if compare else ""
        console.start(sc.name, sc.duration, sc.dt)
        # a spool (rows beyond memory) goes into the run's own folder: --recover finds it
        result = simulate(
            setup, progress=console.progress, record_every=args.record_every, spool_dir=folder
        )
        console.clear()
        _write(folder, sc, setup.robot, result, args, console)
        results.append(result)
        if result.stop_cause == "interrupted":  # Ctrl-C: what was recorded is written; stop
            break
    if compare and not args.no_plots:
        _overlay(results, root, console)
    _report(results, folders[: len(results)], root, console)
    status = EXIT_OK if all(r.completed for r in results) else EXIT_STOPPED
    if any(r.stop_cause == "interrupted" for r in results):
        return EXIT_INTERRUPTED  # no replay server after a Ctrl-C
    if args.meshcat:
        _serve(setups[0].robot, results)
    return status


def _check(scenarios: list[Scenario]) -> int:
    """``--check``: the t = 0 conditions of each scenario; writes nothing."""
    from .check import check

    status = EXIT_OK
    for sc in scenarios:
        loads = _user_code(sc)
        if loads:
            print(f"{sc.name}: controller: {loads}")
        rep = check(sc)
        fmt = lambda v, u="": "n/a" if v is None else f"{v:.4g}{u}"  # noqa: E731
        print(
            f"{sc.name}: sigma_min(0) = {fmt(rep.sigma_min)} (threshold {fmt(rep.threshold)}), "
            f"reach horizon = {fmt(rep.reach_horizon, ' s') if rep.reach_horizon else 'none'}"
            f", base attitude error = {fmt(rep.attitude_error, ' rad')} "
            f"(authority {fmt(rep.authority, ' rad')})"
        )
        if rep.resolved:
            print(f"{sc.name}: {rep.resolved}")
        for problem in rep.problems:
            status = fail(problem)
    return status


def _user_code(sc: Scenario) -> str | None:
    """What a ``file.py:Class`` controller type will run, for ``--check``; None otherwise."""
    from ..control.registry import resolved_type

    kind = sc.controller.type
    where, sep, name = kind.rpartition(":")
    if not sep or not where.endswith(".py"):
        return None
    path = resolved_type(kind, sc.source.parent if sc.source else None).rpartition(":")[0]
    return f"loads and runs {path} (class {name})"


def _scenarios(args: argparse.Namespace) -> list[Scenario]:
    if args.compare is not None:
        found = [sc for item in args.compare or ["planar"] for sc in _compare_item(item)]
    elif args.scenario:
        found = [load_scenario(args.scenario)]
    else:
        found = [builtin_scenario(args.case or "case1")]
    if args.controllers:
        found = [_with_controller(sc, kind) for sc in found for kind in args.controllers]
    names = [sc.name for sc in found]
    if len(set(names)) < len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise ScenarioError(
            f"--compare: scenarios named alike ({', '.join(twice)}); name them apart"
        )
    return found


def _compare_item(item: str) -> list[Scenario]:
    """A ``--compare`` item: a set of built-in cases, a built-in case, or a scenario file."""
    if item in COMPARE_SETS:
        return [builtin_scenario(name) for name in COMPARE_SETS[item]]
    name = _CASE_ALIASES.get(item, item)
    if name in BUILTIN:
        return [builtin_scenario(name)]
    if Path(item).suffix == ".toml" or Path(item).exists():
        return [load_scenario(item)]
    raise ScenarioError(
        f"--compare {item!r}: not a set ({', '.join(COMPARE_SETS)}), a built-in case "
        f"({_case_choices()}) or a scenario file"
    )


def _controller_list(text: str) -> list[str]:
    """``--controllers a,b,c``: controller types; a relative ``file.py`` made absolute."""
    kinds = [k.strip() for k in text.split(",") if k.strip()]
    if not kinds:
        raise argparse.ArgumentTypeError("expected controller types separated by commas")
    out = []
    for kind in kinds:
        where, sep, name = kind.rpartition(":")
        if sep and where.endswith(".py"):
            kind = f"{Path(where).resolve()}:{name}"
        out.append(kind)
    if len(set(out)) < len(out):
        raise argparse.ArgumentTypeError(f"a controller type given twice in {text!r}")
    return out


def _with_controller(sc: Scenario, kind: str) -> Scenario:
    """``sc`` run by controller type ``kind``, named ``<name>-<label>``."""
    from ..control.registry import controller_label

    controller = dataclasses.replace(sc.controller, type=kind)
    return dataclasses.replace(
        sc, controller=controller, name=f"{sc.name}-{controller_label(kind)}"
    )


def _override(sc: Scenario, args: argparse.Namespace) -> Scenario:
    changes = {}
    if args.duration is not None:
        changes["duration"] = args.duration
    if args.dt is not None:
        changes["dt"] = args.dt
    return dataclasses.replace(sc, **changes) if changes else sc


def _recover(args: argparse.Namespace, console: Console) -> int:
    """``--recover DIR``: every spool a killed run left in DIR, written as its run's files."""
    from .recover import recover

    found = recover(args.recover)
    for run in found:
        _write(run.folder, run.setup.scenario, run.setup.robot, run.result, args, console)
    results = [run.result for run in found]
    _report(results, [run.folder for run in found], Path(args.recover), console)
    return EXIT_STOPPED


def _write(folder: Path, scenario: Scenario, robot, result: RunResult, args, console) -> None:
    """Write a run's files as a whole; when they cannot be, keep its spool for --recover."""
    try:
        write_outputs(
            folder,
            result,
            scenario,
            robot,
            figures=not args.no_plots,
            replay=not args.no_html,
            warn=console.warn,
        )
    except OutputError as exc:
        keep = getattr(result.signals, "keep_spool", None)
        spool = keep() if keep is not None else None
        if spool is None:
            raise OutputError(f"{exc}; {folder} keeps what it held before this run") from None
        raise OutputError(
            f"{exc}; {folder} keeps what it held before this run, and this run's recording is "
            f"kept in {spool}: free some space, then python -m ffsm_pin.sim --recover {folder}"
        ) from None


def _report(results: list[RunResult], folders: list[Path], root: Path, console) -> None:
    """The result table (or, quiet, the folder) on stdout; a line per stopped run on stderr."""
    if console.quiet:
        print(root)
    else:
        print(result_table(results, folders))
    for res in results:
        if not res.completed:
            print(f"{res.scenario_name}: {stop_line(res)}", file=sys.stderr)


def _overlay(results: list[RunResult], root: Path, console) -> None:
    """The overlaid figures of a comparison, written into ``root`` as a whole."""
    from .figures import write_figures  # matplotlib only when figures are drawn

    with RunFolder(root) as out:
        try:
            write_figures([r.thinned(PLOT_ROWS) for r in results], out.staging)
        except OSError:
            raise
        except Exception as exc:  # noqa: BLE001 - reported, every run's files are written
            console.warn(f"could not write overlaid figures: {type(exc).__name__}: {exc}")
            return
        out.commit()


class _Terminated(Exception):
    """SIGTERM while the replay server runs (stop it like Ctrl-C, cleaning up)."""


def _raise_terminated(signum, frame) -> None:
    raise _Terminated


def _serve(robot, results: list[RunResult]) -> None:
    from .replay import close_visualizer, serve_replay

    vis = serve_replay(robot, results)  # meshcat prints the URL
    # a SIGTERM (kill, a job scheduler, a terminal closing) also stops meshcat's server process
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        print("meshcat: open the URL above to watch the replay; Ctrl-C stops the server")
        sys.stdout.flush()
        while True:
            time.sleep(1.0)
    except (KeyboardInterrupt, _Terminated):
        pass
    finally:
        close_visualizer(vis)
        signal.signal(signal.SIGTERM, previous)


# ------------------------------------------------------------------------------ helpers
def _out_dir(out: str | None) -> Path:
    if out is not None:
        path = Path(out)
        path.mkdir(parents=True, exist_ok=True)
        return path
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    base = Path("runs")
    base.mkdir(parents=True, exist_ok=True)
    for k in range(1, 1000):
        path = base / (stamp if k == 1 else f"{stamp}-{k}")
        try:
            path.mkdir()
            return path
        except FileExistsError:
            continue
    raise FileExistsError(f"runs/{stamp}: too many runs in the same second")


def _case_choices() -> str:
    """The names --case takes: the aliases, then every other built-in scenario."""
    return ", ".join([*_CASE_ALIASES, *(k for k in BUILTIN if k not in _CASE_ALIASES.values())])


def _case_name(text: str) -> str:
    name = _CASE_ALIASES.get(text, text)
    if name not in BUILTIN:
        raise argparse.ArgumentTypeError(f"unknown case {text!r}; valid choices: {_case_choices()}")
    return name


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "run"
