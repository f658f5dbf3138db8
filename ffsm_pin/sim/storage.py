"""Can a run's recording be stored? Checked before anything is simulated or written.

A run keeps one bounded chunk of its rows in memory and spills the rest to disk as it goes
(:mod:`ffsm_pin.sim.recorder`), then packs them into ``trajectory.npz``: what limits a
recording is the free disk. A request whose rows cannot be stored (a fine step over a long
time, ``--record-every 1``) is bad input, refused at once with what it would need and the
``--record-every`` that would fit, instead of failing in the middle of a run.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..errors import StorageError


def free_disk(folder: str | Path) -> int | None:
    """Free bytes on the file system that holds ``folder`` (its nearest existing parent)."""
    path = Path(folder).resolve()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        return shutil.disk_usage(path).free
    except OSError:
        return None


def file_size_limit() -> int | None:
    """The largest file this process may write [bytes] (``ulimit -f``, RLIMIT_FSIZE), or
    None when there is no limit (or the platform has none)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not on POSIX
        return None
    soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    return None if soft == resource.RLIM_INFINITY else int(soft)


def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TiB"  # pragma: no cover


def rows_recorded(steps: int, record_every: int) -> int:
    """Rows a run of ``steps`` steps records: every ``record_every``-th step, the last step,
    and one spare (as the recorder allocates).

    Parameters
    ----------
    steps : int
        Steps of the run.
    record_every : int
        The recording interval [steps].

    Returns
    -------
    int
        The rows.
    """
    return steps // max(1, int(record_every)) + 2


def check_storage(
    steps: int,
    row_bytes: int,
    record_every: int,
    folder: str | Path,
    *,
    copies: int = 1,
    disk: int | None = None,
) -> None:
    """Raise :class:`StorageError` when the recording of a run does not fit on disk.

    With ``copies`` >= 2 the one file that holds every row, ``trajectory.npz``, is also
    checked against the process's file-size limit (:func:`file_size_limit`).

    Parameters
    ----------
    steps, row_bytes : int
        Steps of the run and bytes of one recorded row (``ffsm_pin.sim.recording.recording_size``).
    record_every : int
        The run's recording interval [steps]; the error names the smallest one that fits.
    folder : str or Path
        Folder whose file system holds the recording.
    copies : int
        Raw copies of the rows that folder must hold at once: 1 for the recorder's spool,
        2 for a spool beside the ``trajectory.npz`` packed from it (stored without
        compression: the raw size and a header per signal).
    disk : int or None
        Free disk [bytes]; read from the system when None.
    """
    rows = rows_recorded(steps, record_every)
    limit = file_size_limit() if copies >= 2 else None
    if limit is not None and rows * row_bytes > limit:
        text = (
            f"the run's trajectory.npz would hold {rows:,} rows of {row_bytes:,} bytes "
            f"({_size(rows * row_bytes)}), more than the {_size(limit)} this process may write "
            "into one file (ulimit -f)"
        )
        fit = _fitting_interval(steps, row_bytes, float(limit))
        if fit is None:
            raise StorageError(f"{text}; raise the limit, shorten the run or enlarge dt")
        raise StorageError(f"{text}; use --record-every {fit} (or more) or raise the limit")
    need = copies * rows * row_bytes
    disk = free_disk(folder) if disk is None else disk
    if disk is None or need <= disk:
        return
    what = (
        "recording" if copies == 1 else f"recording ({copies} copies: the rows and trajectory.npz)"
    )
    text = (
        f"the run would record {rows:,} rows of {row_bytes:,} bytes; its {what} needs "
        f"{_size(need)}, more than the {_size(disk)} of free disk in {folder}"
    )
    fit = _fitting_interval(steps, copies * row_bytes, float(disk))
    if fit is None:
        raise StorageError(f"{text}; shorten the run or enlarge dt")
    raise StorageError(
        f"{text}; use --record-every {fit} (or more), a shorter duration or a larger dt"
    )


def _fitting_interval(steps: int, row_bytes: int, budget: float) -> int | None:
    """The smallest recording interval whose rows fit in ``budget`` bytes, or None."""
    max_rows = int(budget // row_bytes)
    if max_rows < 3:  # the first, the last and the spare row at the least
        return None
    k = steps // (max_rows - 1) + 1  # floor(steps / k) <= max_rows - 2
    while k > 1 and rows_recorded(steps, k - 1) <= max_rows:
        k -= 1
    while rows_recorded(steps, k) > max_rows:
        k += 1
    return k
