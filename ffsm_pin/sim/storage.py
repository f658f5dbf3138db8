"""Can a run's recording be stored? Checked before anything is allocated.

A run records every signal of every recorded step and holds them in memory until it ends,
then writes ``trajectory.npz``. A request that cannot be held (a fine step over a long time,
``--record-every 1``) is bad input, refused at once with what it would need and the
``--record-every`` that would fit, instead of failing in the middle of an allocation.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..errors import StorageError

# the recording is held in memory, and summarising and writing it needs temporaries of about
# its own size: a recording may take at most this share of the available memory
MEMORY_SHARE = 0.5


def available_memory() -> int | None:
    """Memory the system can give without swapping [bytes] (``MemAvailable``), or None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def free_disk(folder: str | Path) -> int | None:
    """Free bytes on the file system that holds ``folder`` (its nearest existing parent)."""
    path = Path(folder).resolve()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        return shutil.disk_usage(path).free
    except OSError:
        return None


def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TiB"  # pragma: no cover


def rows_recorded(steps: int, record_every: int) -> int:
    """Rows a run of ``steps`` steps records: every ``record_every``-th step, the last step,
    and one spare (as the recorder allocates)."""
    return steps // max(1, int(record_every)) + 2


def check_storage(
    steps: int,
    row_bytes: int,
    record_every: int,
    folder: str | Path | None = None,
    *,
    memory: int | None = None,
    disk: int | None = None,
) -> None:
    """Raise :class:`StorageError` when the recording of a run does not fit.

    Parameters
    ----------
    steps, row_bytes:
        Steps of the run and bytes of one recorded row (``ffsm_pin.sim.run.recording_size``).
    record_every:
        The run's recording interval [steps]; the error names the smallest one that fits.
    folder:
        Output folder whose disk must hold ``trajectory.npz`` (at most the raw size).
    memory, disk:
        Available memory and free disk [bytes]; read from the system when None.
    """
    rows = rows_recorded(steps, record_every)
    need = rows * row_bytes
    memory = available_memory() if memory is None else memory
    if folder is not None and disk is None:
        disk = free_disk(folder)
    limits = []
    if memory is not None:
        limits.append(
            (
                MEMORY_SHARE * memory,
                f"{_size(memory)} of available memory (a run "
                f"holds its recording in memory; at most {MEMORY_SHARE:.0%} is used)",
            )
        )
    if folder is not None and disk is not None:
        limits.append((float(disk), f"{_size(disk)} of free disk in {folder}"))
    for budget, what in limits:
        if need <= budget:
            continue
        text = (
            f"the run would record {rows:,} rows of {row_bytes:,} bytes = {_size(need)}, "
            f"more than the {what}"
        )
        fit = _fitting_interval(steps, row_bytes, budget)
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
