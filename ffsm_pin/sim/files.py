"""Files written as a whole (docs/cli.md, "What is kept when something fails").

Every file of a run (``trajectory.npz``, ``summary.json``, ``scenario.toml``, the figures,
``replay.html``) is first written into a hidden staging folder inside the output folder (the
same file system, so that a rename is atomic), then renamed into place: the earlier run's
``summary.json`` is removed first, the new one renamed in last, and the earlier run's files the
new run does not write (its figures after ``--no-plots``, say) are removed at the end. A
failure before the renames (a full disk, a file-size limit, a Ctrl-C pressed twice) removes the
staging folder and leaves the earlier run exactly as it was; an I/O failure is an
:class:`~ffsm_pin.errors.OutputError` naming the file.

A first Ctrl-C while the files are written is held back until they are complete (the run's
files are written, then the interrupt is raised); a second one abandons them.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from ..errors import OutputError

#: The files of a run (and the figures, :data:`RUN_PATTERNS`): what a new run replaces.
RUN_FILES = ("trajectory.npz", "summary.json", "scenario.toml", "estimates.json", "replay.html")
RUN_PATTERNS = ("fig_*.png",)
#: The file renamed into place last: its presence says the run's files are complete.
COMMIT_FILE = "summary.json"
STAGING_PREFIX = ".ffsm-staging-"


class RunFolder:
    """A run's files staged beside the folder they replace, then renamed in as a whole.

    Use as a context manager: files are written to :meth:`path`, :meth:`commit` moves them
    into ``folder``; leaving the block without a commit (an exception) removes what was
    staged and leaves ``folder`` as it was.

    Parameters
    ----------
    folder : str or Path
        The output folder (created if needed).
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            remove_dead_staging(self.folder)
            self.staging = Path(
                tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{os.getpid()}-", dir=self.folder)
            )
        except OSError as exc:
            raise output_error(exc, self.folder) from None
        self.committed: list[Path] = []

    def path(self, name: str) -> Path:
        """Where the file ``name`` of the run is written before the commit."""
        return self.staging / name

    def commit(self) -> list[Path]:
        """Rename every staged file into the folder (:data:`COMMIT_FILE` last), remove the
        earlier run's files that were not written again; return the paths."""
        names = sorted(p.name for p in self.staging.iterdir())
        order = [n for n in names if n != COMMIT_FILE] + [n for n in names if n == COMMIT_FILE]
        try:
            with contextlib.suppress(FileNotFoundError):  # the earlier run is now incomplete
                (self.folder / COMMIT_FILE).unlink()
            for name in order:
                os.replace(self.staging / name, self.folder / name)
            for stale in run_files(self.folder):
                if stale.name not in names:
                    stale.unlink()
            self.staging.rmdir()
        except OSError as exc:
            raise output_error(exc, self.folder) from None
        self.committed = [self.folder / n for n in order]
        return self.committed

    def abort(self) -> None:
        """Remove what was staged; the folder keeps the earlier run."""
        shutil.rmtree(self.staging, ignore_errors=True)

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.staging.exists():
            self.abort()


@contextlib.contextmanager
def replaced_file(path: str | Path) -> Iterator[Path]:
    """Write one file as a whole: yields a temporary name ``.<name>.<pid>.tmp`` in the same
    folder, renamed to ``path`` when the block ends; removed if it raises (a reader sees the
    old file or the new one, never a part)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def check_writable(folder: str | Path) -> Path:
    """Make ``folder`` and write a small file into it (removed again): raise
    :class:`OutputError` naming it before anything is simulated when it cannot hold a run."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".ffsm-probe-"):
            pass
    except OSError as exc:
        raise output_error(exc, folder) from None
    return folder


def run_files(folder: Path) -> list[Path]:
    """The files of a run in ``folder`` (:data:`RUN_FILES` and :data:`RUN_PATTERNS`)."""
    found = [folder / name for name in RUN_FILES if (folder / name).is_file()]
    for pattern in RUN_PATTERNS:
        found += sorted(p for p in folder.glob(pattern) if p.is_file())
    return found


def remove_dead_staging(folder: Path) -> None:
    """Remove staging folders that a process which no longer runs left in ``folder``."""
    for path in folder.glob(f"{STAGING_PREFIX}*"):
        pid = path.name[len(STAGING_PREFIX) :].split("-", 1)[0]
        if pid.isdigit() and not pid_alive(int(pid)):
            shutil.rmtree(path, ignore_errors=True)


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (a process of another user counts)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:  # pragma: no cover - other platforms
        return False
    return True


def output_error(exc: OSError, where: Path) -> OutputError:
    """An :class:`OutputError` naming the file of ``exc`` (or ``where``) and the reason.

    Parameters
    ----------
    exc : OSError
        The failure.
    where : Path
        The file written, when ``exc`` names none.

    Returns
    -------
    OutputError
        The error to raise.
    """
    name = exc.filename or where
    reason = exc.strerror or str(exc) or type(exc).__name__
    return OutputError(f"cannot write {str(name)!r}: {reason}")


def strict_json(data: Any) -> str:
    """``data`` as strict JSON (RFC 8259): non-finite numbers become ``null``."""

    def clean(x: Any) -> Any:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, Mapping):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(data), indent=2, allow_nan=False) + "\n"


@contextlib.contextmanager
def held_interrupt(announce: Callable[[str], None] | None = None) -> Iterator[None]:
    """Hold a first Ctrl-C back until the block ends (then raise it); a second one raises at
    once. Only in the main thread (elsewhere, signals cannot be handled)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pressed: list[bool] = []

    def handler(signum, frame) -> None:
        if pressed:
            raise KeyboardInterrupt
        pressed.append(True)
        if announce is not None:
            announce("writing the run's files; Ctrl-C again to abandon them")

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        raise KeyboardInterrupt
