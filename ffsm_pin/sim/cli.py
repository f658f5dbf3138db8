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
import math
import signal
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from .._cli import Parser, UsageError, fail, positive_float, positive_int
from ..errors import FfsmError, OutputError
from ..scenario.file import BUILTIN, builtin_scenario, load_scenario
from ..scenario.spec import Scenario
from .compile_note import note_compilation
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
    p = Parser(
        prog="python -m ffsm_pin.sim",
        description="Simulate a free-floating space manipulator under the adaptive "
        "prescribed-performance coordinated controller of Lu & Jia (2019).",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
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
        nargs="?",
        const="planar",
        default=None,
        choices=tuple(COMPARE_SETS),
        metavar="SET",
        help="run cases 1, 2 and 3 (SET 'planar', the default) or the spatial cases spatial, "
        "spatial-no-ppc and spatial-no-attitude (SET 'spatial') and overlay their figures",
    )
    what.add_argument("--scenario", metavar="FILE.toml", help="run a scenario file")
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
    from .loop import recording_size, simulate  # heavy imports: command line is fine
    from .setup import prepare
    from .storage import check_storage

    scenarios = [_override(sc, args) for sc in _scenarios(args)]
    note_compilation(args.quiet)
    if args.check:
        return _check(scenarios)
    setups = []
    for sc in scenarios:  # every bad input before any simulation
        console.context = sc.name if len(scenarios) > 1 else ""
        setups.append(prepare(sc))
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
    if args.compare:
        return [builtin_scenario(name) for name in COMPARE_SETS[args.compare]]
    if args.scenario:
        return [load_scenario(args.scenario)]
    return [builtin_scenario(args.case or "case1")]


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


# ------------------------------------------------------------------------------ reporting
def stop_line(result: RunResult) -> str:
    """One line: at which time the run stopped, and why."""
    t = result.stop_time
    if t is None and len(result["t"]):
        t = float(result["t"][-1])
    reason = (result.stop_reason or "unknown reason").replace("\n", " ")
    when = f"t = {t:.4g} s" if t is not None else "an unknown time"
    if reason.startswith("t ="):
        return f"run stopped early: {reason}"
    return f"run stopped early at {when}: {reason}"


def result_table(results: Sequence[RunResult], folders: Sequence[Path]) -> str:
    """The short table printed at the end: one column per run."""
    columns = [_column(r, f) for r, f in zip(results, folders, strict=True)]
    keys = list(columns[0])
    if len(results) == 1:
        keys.remove("scenario")
    width = max(len(k) for k in keys)
    cols = [max(len(c[k]) for k in keys) for c in columns]
    lines = []
    for key in keys:
        cells = "  ".join(c[key].ljust(w) for c, w in zip(columns, cols, strict=True))
        lines.append(f"{key.ljust(width)}  {cells}".rstrip())
    return "\n".join(lines)


def _column(r: RunResult, folder: Path) -> dict[str, str]:
    s = r.summary()
    spatial = np.asarray(r["err_b"]).shape[-1] == 3  # (rows, m3), rows may be 0
    n_z = np.asarray(r["err_z"]).shape[-1]
    b_unit = "MRP" if spatial else "rad"
    z_unit = ("m" if n_z == 3 else "m,MRP") if spatial else ("m" if n_z == 2 else "m,m,rad")
    settle = f"{_num(s['settle_time_b'], '{:.2f}')} / {_num(s['settle_time_z'], '{:.2f}')}"
    return {
        "scenario": r.scenario_name,
        "controller": r.controller + (f" ({r.scheme})" if r.scheme else ""),
        "completed": _completed(r),
        "funnel b / z": f"{_kept(s['funnel_ok_b'])} / {_kept(s['funnel_ok_z'])}",
        "first violation [s]": _num(s["first_violation_t"], "{:.3f}"),
        f"final err_b [{b_unit}]": _vec(s["final_err_b"]),
        f"final err_z [{z_unit}]": _vec(s["final_err_z"]),
        "settle b / z [s]": settle,
        "max |u_m| [N m]": _num(s["max_abs_u"], "{:.4g}"),
        "max |F_r| [N m]": _num(s.get("max_abs_F_r"), "{:.4g}"),
        "min sigma_min [m]": _num(s.get("min_sigma"), "{:.3g}"),
        "drift P [kg m/s]": _num(s["drift_P"], "{:.2e}"),
        "drift L [kg m^2/s]": _num(s["drift_L"], "{:.2e}"),
        "simulated [s]": f"{s['simulated_time']:.3f} of {r.duration:g}",
        "wall time [s]": f"{r.wall_time_s:.2f}",
        "steps per second": _num(s["steps_per_s"], "{:.0f}"),
        "output": str(folder),
    }


def _completed(r: RunResult) -> str:
    if r.completed:
        return "yes"
    t = r.stop_time if r.stop_time is not None else (float(r["t"][-1]) if len(r["t"]) else 0)
    return f"no, stopped at {t:.3f} s"


def _kept(ok: bool) -> str:
    return "kept" if ok else "LEFT"


def _num(x, fmt: str) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-" if x is None else str(x)
    return fmt.format(x)


def _vec(values) -> str:
    if not values:
        return "-"
    return "[" + ", ".join(f"{v:.2e}" for v in values) + "]"


class Console:
    """Progress bar (tqdm, on stderr, erased at the end) and ``warning: ...`` lines."""

    def __init__(self, quiet: bool = False, stream: TextIO | None = None, width: int = 24):
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self._bar = None
        self._dt = 1.0
        self._seen: set[str] = set()
        self.context = ""  # prefix of warnings (the run they belong to)
        self._interval = 0.1 if _isatty(self.stream) else 2.0  # [s] between redraws

    def start(self, name: str, duration: float, dt: float) -> None:
        """Open the progress bar of a run of ``duration`` [s] in steps of ``dt`` [s]."""
        from tqdm import tqdm  # the same progress library as the campaigns (ffsm_pin.sweep)

        self._close()
        if self.quiet:
            return
        self._dt = dt
        self._bar = tqdm(
            total=duration,
            desc=name,
            file=self.stream,
            leave=False,
            mininterval=self._interval,
            ascii=".#",
            postfix="     0 steps/s",
            bar_format=f"{{desc}} [{{bar:{self.width}}}] {{n:6.2f}}/{{total:g}} s  {{postfix}}  "
            "ETA {remaining}",
        )
        self.progress(0.0)

    def progress(self, t: float) -> None:
        """Callback for :func:`ffsm_pin.sim.loop.simulate`: t = simulated time [s]."""
        bar = self._bar
        if bar is None:
            return
        elapsed = bar.format_dict["elapsed"]
        rate = t / self._dt / elapsed if elapsed > 0 else 0.0
        bar.set_postfix_str(f"{rate:6.0f} steps/s", refresh=False)
        bar.update(min(t, bar.total) - bar.n)

    def clear(self) -> None:
        """Erase the bar (it is drawn again at the next progress update of an unfinished run)."""
        if self._bar is None:
            return
        if self._bar.n >= self._bar.total:
            self._close()
        else:
            self._bar.clear()

    def _close(self) -> None:
        if self._bar is not None:
            try:
                self._bar.close()
            except (OSError, ValueError):  # closed pipe: progress is best effort
                pass
            self._bar = None

    def warn(self, message: str) -> None:
        """Print a ``warning:`` line without breaking the progress bar (unless quiet)."""
        if self.quiet:
            return
        self.clear()
        self._write(f"warning: {message}\n")

    def show_warning(self, message, category, filename, lineno, file=None, line=None) -> None:
        """Replacement for :func:`warnings.showwarning`: one ``warning: ...`` line."""
        text = " ".join(str(message).split())
        if self.context:
            text = f"{self.context}: {text}"
        if text in self._seen:
            return
        self._seen.add(text)
        self.warn(text)

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # closed pipe: progress is best effort
            pass


# ------------------------------------------------------------------------------ helpers
def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


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
