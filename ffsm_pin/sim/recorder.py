"""The run's recorder: rows held in one bounded chunk in memory, spilled to disk when it fills.

A run records one row of every per-step signal (``ffsm_pin.sim.recording.recorder_shapes``) at every
recorded step. The rows are written into a chunk of :data:`CHUNK_BYTES`; when it is full, each
signal's rows are appended to a raw file ``<key>.bin`` in a spool folder, so the memory a run
holds does not grow with its duration. A run whose rows fit in one chunk never touches the
disk and its signals are plain arrays; a longer run's signals are read-only memory maps of
the spool files (:class:`Signals`), read back in blocks by the summary, the figures and the
``trajectory.npz`` writer (:func:`write_npz`), never all at once. The bytes are copied, never
recomputed, so a spilled recording equals an in-memory one bit for bit (tests/sim/test_recorder.py).

See docs/cli.md, "Long runs".
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import tempfile
import time
import weakref
import zipfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .chunk_pool import ChunkPool

# rows held in memory: as many as fit in this many bytes (at least one)
CHUNK_BYTES = 32 * 2**20
# rows read at a time when a spilled recording is summarised, decimated or packed
BLOCK_BYTES = 16 * 2**20
#: A spool folder's name starts with this; its header file (written before any row) is
#: :data:`SPOOL_HEADER`, in the format :data:`SPOOL_FORMAT`.
SPOOL_PREFIX = ".ffsm-spool-"
SPOOL_HEADER = "spool.json"
SPOOL_FORMAT = "ffsm-pin spool 1"


class Signals(Mapping):
    """Recorded signals by key: in-memory arrays, or memory maps of a spool folder.

    Behaves as a read-only ``dict`` of arrays (time along axis 0). :meth:`blocks` and
    :meth:`every` read spilled signals through the file, a block at a time, so that code
    which must see every row does not map a whole long recording into memory.

    Parameters
    ----------
    arrays : dict of str to ndarray
        The in-memory signals.
    spool : Path or None
        The spool folder of the spilled ones (removed with the signals).
    shapes : dict of str to tuple of int or None
        Row shape of each spilled signal.
    rows : int
        Rows of the spilled signals.
    """

    def __init__(
        self,
        arrays: dict[str, np.ndarray],
        spool: Path | None = None,
        shapes: dict[str, tuple[int, ...]] | None = None,
        rows: int = 0,
    ):
        self._arrays = dict(arrays)
        self._spool = spool
        self._shapes = dict(shapes or {})  # spilled keys -> row shape
        self._rows = rows
        self._maps: dict[str, np.ndarray] = {}
        self._finalizer = None
        if spool is not None:  # the folder lives as long as the signals
            self._finalizer = weakref.finalize(self, shutil.rmtree, spool, True)

    # ------------------------------------------------------------------ Mapping
    def __getitem__(self, key: str) -> np.ndarray:
        if key in self._arrays:
            return self._arrays[key]
        if key not in self._shapes:
            raise KeyError(key)
        if key not in self._maps:
            shape = (self._rows, *self._shapes[key])
            if self._rows == 0:
                self._maps[key] = np.zeros(shape)
            else:
                self._maps[key] = np.memmap(self._file(key), np.float64, "r", shape=shape)
        return self._maps[key]

    def __iter__(self) -> Iterator[str]:
        yield from self._shapes
        yield from (k for k in self._arrays if k not in self._shapes)

    def __len__(self) -> int:
        return len(self._shapes) + sum(k not in self._shapes for k in self._arrays)

    @property
    def spool(self) -> Path | None:
        """The spool folder the rows live in, or None when they are in memory."""
        return self._spool

    def keep_spool(self) -> Path | None:
        """Keep the spool folder after these signals are gone (a run whose files could not be
        written: ``python -m ffsm_pin.sim --recover`` reads it); its path, or None."""
        if self._finalizer is not None:
            self._finalizer.detach()
        return self._spool

    # ------------------------------------------------------------------ blocks
    @property
    def spilled(self) -> bool:
        """True when the rows live on disk (memory maps), False when in memory."""
        return bool(self._shapes)

    def row_bytes(self, keys) -> int:
        """Bytes of one row of the per-row signals among ``keys``."""
        return sum(8 * int(np.prod(self[k].shape[1:])) for k in keys)

    def blocks(self, keys, rows: int | None = None) -> Iterator[dict[str, np.ndarray]]:
        """Consecutive row blocks ``{key: rows x shape}`` of the per-row signals ``keys``.

        In-memory signals are sliced; spilled ones are read from their files.

        Parameters
        ----------
        keys : iterable of str
            Per-row signals.
        rows : int or None
            Rows per block; None: a block of about :data:`BLOCK_BYTES`.

        Yields
        ------
        dict of str to ndarray
            The next block.
        """
        keys = list(keys)
        n = len(self["t"])
        if rows is None:
            rows = max(1, BLOCK_BYTES // max(1, self.row_bytes(keys)))
        for start in range(0, n, rows):
            stop = min(n, start + rows)
            yield {k: self._read(k, start, stop) for k in keys}

    def every(self, key: str, step: int) -> np.ndarray:
        """Rows ``0, step, 2 step, ...`` of ``key`` and its last row, in memory.

        Parameters
        ----------
        key : str
            The signal.
        step : int
            Row stride.

        Returns
        -------
        ndarray
            The rows.
        """
        n = len(self["t"])
        if step <= 1 or n == 0:
            return np.asarray(self._read(key, 0, n))
        parts = []
        rows = max(step, (BLOCK_BYTES // max(1, self.row_bytes([key]))) // step * step)
        for start in range(0, n, rows):
            parts.append(self._read(key, start, min(n, start + rows))[::step])
        if (n - 1) % step:
            parts.append(self._read(key, n - 1, n))
        return np.concatenate(parts)

    def _file(self, key: str) -> Path:
        assert self._spool is not None
        return self._spool / f"{key}.bin"

    def _read(self, key: str, start: int, stop: int) -> np.ndarray:
        if key not in self._shapes:
            return self[key][start:stop]
        shape = self._shapes[key]
        width = int(np.prod(shape))
        count = (stop - start) * width
        if count == 0:
            return np.zeros((0, *shape))
        data = np.fromfile(self._file(key), np.float64, count=count, offset=8 * start * width)
        return data.reshape(stop - start, *shape)


class Recorder:
    """Rows of the per-step signals ``shapes`` (key -> row shape), held a chunk at a time.

    The run loop writes row :attr:`i` of :attr:`arrays` (each ``chunk_rows x shape``, NaN until
    written) and calls :meth:`commit` when the row is complete; a row not committed (a step
    that raised, Ctrl-C) is not recorded. :meth:`finish` returns the :class:`Signals`.

    Parameters
    ----------
    shapes : dict of str to tuple of int
        Row shape of every per-step signal.
    capacity : int
        Upper bound of the rows the run records (``ffsm_pin.sim.storage.rows_recorded``).
    spool_dir : str or Path or None
        Folder in which the spool folder of a recording longer than one chunk is made (the
        system's temporary folder when None). Removed when the signals are no longer used.
    chunk_bytes : int or None
        Memory for the rows held at once [bytes]; :data:`CHUNK_BYTES` when None.
    packed : sequence of str
        Keys of ``shapes`` held side by side, in this order, in :attr:`block` (``chunk_rows x
        width``): row :attr:`i` of it is their row, written in one copy (a controller's
        :class:`~ffsm_pin.control.interface.SignalRow`); their :attr:`arrays` are views of it.
    header : callable or None
        Called when the spool folder is made: what the spool says of its run (JSON-able), written
        into :data:`SPOOL_HEADER` with the row shapes before any row, so that the rows of a run
        killed before its end can be read back (:mod:`ffsm_pin.sim.recover`).
    pool : ChunkPool or None
        Where the chunk's memory comes from (:mod:`ffsm_pin.sim.chunk_pool`: memory reused
        within a campaign worker); fresh memory when None.
    """

    def __init__(
        self,
        shapes: dict[str, tuple[int, ...]],
        capacity: int,
        spool_dir: str | Path | None = None,
        chunk_bytes: int | None = None,
        packed: Sequence[str] = (),
        header: Callable[[], Mapping[str, Any]] | None = None,
        pool: ChunkPool | None = None,
    ):
        self._header = header
        full = np.full if pool is None else pool.full
        chunk_bytes = CHUNK_BYTES if chunk_bytes is None else chunk_bytes
        self.shapes = dict(shapes)
        row = sum(8 * int(np.prod(s)) for s in self.shapes.values())
        self.chunk_rows = int(max(1, min(capacity, chunk_bytes // max(1, row))))
        widths = [int(np.prod(self.shapes[key])) for key in packed]
        self.block = full((self.chunk_rows, sum(widths)), np.nan)
        views, start = {}, 0
        for key, width in zip(packed, widths, strict=True):
            views[key] = self.block[:, start : start + width].reshape(
                self.chunk_rows, *self.shapes[key]
            )
            start += width
        self.arrays = {
            k: views[k] if k in views else full((self.chunk_rows, *s), np.nan)
            for k, s in self.shapes.items()
        }
        self.i = 0  # row of the chunk being written
        self.on_disk = 0  # rows already spilled
        self._spool_dir = spool_dir
        self._spool: Path | None = None
        self.notes: dict[str, dict] = {}  # kept beside the rows in a spool (note)

    def note(self, name: str, data: Mapping[str, Any]) -> None:
        """Keep ``data`` (JSON-able) with the rows: in a spool as ``<name>.json``, written now
        if the spool exists, else when it is made, so that a run killed after it can be
        recovered with it (a capture's grasp, :mod:`ffsm_pin.sim.recover`).

        Parameters
        ----------
        name : str
            The note's name (a file name).
        data : mapping
            What it says.
        """
        self.notes[name] = dict(data)
        if self._spool is not None:
            write_note(self._spool, name, self.notes[name])

    @property
    def rows(self) -> int:
        """Rows committed so far."""
        return self.on_disk + self.i

    def commit(self) -> None:
        """The row :attr:`i` is complete: keep it; spill the chunk when it is full."""
        self.i += 1
        if self.i == self.chunk_rows:
            self._spill()

    def write_rows(
        self, columns: Mapping[str, np.ndarray], block: np.ndarray | None = None
    ) -> None:
        """Record whole rows at once, as that many :meth:`commit`-ed rows (the bytes copied):
        ``columns`` key -> rows of each unpacked signal, ``block`` the packed signals' rows
        side by side (a lock-step run's, :mod:`ffsm_pin.sim.lockstep`).

        Parameters
        ----------
        columns : mapping of str to ndarray
            Each unpacked signal's rows.
        block : ndarray or None
            The packed signals' rows (None: there are none).
        """
        rows = len(block) if block is not None else len(next(iter(columns.values())))
        done = 0
        while done < rows:
            i, n = self.i, min(self.chunk_rows - self.i, rows - done)
            for key, values in columns.items():
                self.arrays[key][i : i + n] = values[done : done + n]
            if block is not None:
                self.block[i : i + n] = block[done : done + n]
            done, self.i = done + n, i + n
            if self.i == self.chunk_rows:
                self._spill()

    def _spill(self) -> None:
        if self.i == 0:
            return
        if self._spool is None:
            self._spool = make_spool(self.shapes, self._spool_dir, self._header)
            for name, data in self.notes.items():
                write_note(self._spool, name, data)
        for key, chunk in self.arrays.items():
            width = chunk[0].size
            with open(self._spool / f"{key}.bin", "r+b" if self.on_disk else "wb") as f:
                f.seek(8 * self.on_disk * width)  # a spill cut short is simply redone
                f.write(np.ascontiguousarray(chunk[: self.i]).data)  # (its buffer: no bytes copy)
        self.on_disk += self.i
        self.i = 0

    def finish(self) -> Signals:
        """The recorded rows: in-memory arrays if they never left the chunk, else memory maps.

        In memory, packed columns (``packed``) stay views of their block, so any one of them
        keeps the block's memory (copying them out cost a spatial run ~3 us a row,
        benchmarks/README.md).
        """
        if self._spool is None:
            return Signals({k: a[: self.i] for k, a in self.arrays.items()})
        self._spill()
        self.arrays, self.block = {}, np.empty((0, 0))  # the chunk's memory is no longer needed
        return Signals({}, self._spool, self.shapes, self.on_disk)


def make_spool(
    shapes: Mapping[str, tuple[int, ...]],
    folder: str | Path | None,
    header: Callable[[], Mapping[str, Any]] | None = None,
) -> Path:
    """A new spool folder in ``folder`` (the system's temporary folder when None) whose
    :data:`SPOOL_HEADER` names the process, the row shapes (float64, C order, one raw file
    ``<key>.bin`` per signal) and ``header()``.

    Parameters
    ----------
    shapes : mapping of str to tuple of int
        Row shape of each signal.
    folder : str or Path or None
        Where the spool is made.
    header : callable or None
        What else the header holds.

    Returns
    -------
    Path
        The spool folder.
    """
    if folder is not None:
        Path(folder).mkdir(parents=True, exist_ok=True)
    spool = Path(tempfile.mkdtemp(prefix=f"{SPOOL_PREFIX}{os.getpid()}-", dir=folder))
    about = {
        "format": SPOOL_FORMAT,
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "dtype": "<f8",
        "shapes": {k: list(v) for k, v in shapes.items()},
        **(dict(header()) if header is not None else {}),
    }
    tmp = spool / (SPOOL_HEADER + ".tmp")
    tmp.write_text(json.dumps(about, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, spool / SPOOL_HEADER)
    return spool


def write_note(spool: Path, name: str, data: Mapping[str, Any]) -> None:
    """Write ``<name>.json`` into ``spool`` whole or not at all (:meth:`Recorder.note`).

    Parameters
    ----------
    spool : Path
        The spool folder.
    name : str
        The note's name.
    data : mapping
        What it says (JSON-able).
    """
    tmp = spool / f"{name}.json.tmp"
    tmp.write_text(json.dumps(dict(data), indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, spool / f"{name}.json")


def extend(
    signals: Signals,
    per_row: Callable[[Mapping[str, np.ndarray]], dict[str, np.ndarray]],
    constants: dict[str, np.ndarray],
    inputs: tuple[str, ...] = ("t",),
) -> Signals:
    """``signals`` plus the per-row signals ``per_row(block)`` computes from the recorded
    columns ``inputs`` (``block``: ``{key: rows x shape}``) and the ``constants`` (arrays
    without a time axis); computed a block at a time when spilled.

    Parameters
    ----------
    signals : Signals
        The recording.
    per_row : callable
        block -> the new per-row signals of the block.
    constants : dict of str to ndarray
        New signals without a time axis.
    inputs : tuple of str
        The recorded columns ``per_row`` reads.

    Returns
    -------
    Signals
        The signals with the new ones.
    """
    if not signals.spilled:
        arrays = dict(signals._arrays)
        arrays.update(per_row({k: arrays[k] for k in inputs}))
        arrays.update(constants)
        return Signals(arrays)
    spool = signals._spool
    assert spool is not None
    shapes = dict(signals._shapes)

    def empty(rows: int) -> dict[str, np.ndarray]:
        return {k: np.zeros((rows, *shapes[k])) for k in inputs}

    files: dict[str, object] = {}
    # blocks sized by what per_row makes of them (with room for its temporaries), not by the
    # 8 bytes of t: a block of the whole t column made hundreds of MB of signals at once
    width = sum(int(np.prod(v.shape[1:])) for v in per_row(empty(1)).values())
    width += sum(int(np.prod(shapes[k])) for k in inputs)
    rows = max(1, BLOCK_BYTES // (8 * 4 * (width + 1)))
    try:
        for block in signals.blocks(list(inputs), rows=rows):
            for key, value in per_row(block).items():
                if key not in files:
                    shapes[key] = value.shape[1:]
                    files[key] = open(spool / f"{key}.bin", "wb")  # noqa: SIM115
                files[key].write(np.ascontiguousarray(value, np.float64).data)  # type: ignore[attr-defined]
    finally:
        for f in files.values():
            f.close()  # type: ignore[attr-defined]
    if signals._rows == 0:  # no block: shapes from an empty call
        for key, value in per_row(empty(0)).items():
            shapes[key] = value.shape[1:]
    assert signals._finalizer is not None
    signals._finalizer.detach()  # handed over: the new object owns the folder
    return Signals(constants, spool, shapes, signals._rows)


def write_npz(path: str | Path, signals: Mapping[str, np.ndarray], compress: bool = False) -> None:
    """Write ``signals`` as ``path`` (``numpy.savez`` format, or ``numpy.savez_compressed``
    with ``compress``; readable by ``numpy.load``), streaming spilled signals from their files
    a block at a time.

    Parameters
    ----------
    path : str or Path
        The file.
    signals : mapping of str to ndarray
        The signals.
    compress : bool
        ``numpy.savez_compressed`` instead of ``numpy.savez``.
    """
    if not isinstance(signals, Signals) or not signals.spilled:
        arrays: dict[str, Any] = dict(signals)
        (np.savez_compressed if compress else np.savez)(path, **arrays)
        return
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(path, "w", compression=method, allowZip64=True) as zf:
        for key in signals:
            arr = signals[key]
            with zf.open(f"{key}.npy", "w", force_zip64=True) as f:
                if key not in signals._shapes:
                    np.lib.format.write_array(f, np.asanyarray(arr), allow_pickle=False)
                    continue
                header = {"descr": "<f8", "fortran_order": False, "shape": arr.shape}
                np.lib.format.write_array_header_2_0(f, header)  # type: ignore[attr-defined]
                for block in signals.blocks([key]):
                    f.write(np.ascontiguousarray(block[key]).data)
