"""signals.parquet: the decimated signals of every case (:mod:`ffsm_pin.sweep.explain`), one
row per kept sample (at most 500 per case), columns :data:`SIGNAL_TYPES`.

The campaign holds none of them in memory: each case's rows are written, as they arrive, to a
small file in the hidden folder ``.signals-parts/`` beside it; :meth:`SignalsFile.write` (called
with every rewrite of results.parquet) streams the earlier signals.parquet, less the cases that
are no longer rows or were run again, and the new parts into a temporary file, renames it in
place of the old one and removes the parts it took. A campaign killed outright leaves parts
behind; they are removed when the folder's next campaign records its first case (their rows
are run again, like the rows results.parquet lost).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from .explain import SIGNAL_KEYS

__all__ = ["SIGNAL_TYPES", "SignalsFile", "signal_rows"]

#: The columns of signals.parquet: the vector signals as lists (one entry per component or
#: joint).
SIGNAL_TYPES = {
    "case": pa.int64(),
    "case_hash": pa.string(),
    "t": pa.float64(),
    **{key: pa.list_(pa.float64()) for key in SIGNAL_KEYS},
}
SCHEMA = pa.schema(list(SIGNAL_TYPES.items()))


def signal_rows(case: int, case_hash: str, signals: Mapping[str, Any]) -> pa.Table:
    """A case's signals ``{"t": (r,), key: (r, k)}`` as rows of signals.parquet (a key that
    is missing is null).

    Parameters
    ----------
    case : int
        The case's index.
    case_hash : str
        Its hash.
    signals : mapping
        Its signals.

    Returns
    -------
    pyarrow.Table
        The rows.
    """
    t = np.asarray(signals["t"], dtype=float).reshape(-1)
    r = len(t)
    arrays: list[pa.Array] = [
        pa.array(np.full(r, case, dtype=np.int64)),
        pa.array([case_hash] * r, pa.string()),
        pa.array(t),
    ]
    for key in SIGNAL_KEYS:
        if key in signals:
            a = np.asarray(signals[key], dtype=float).reshape(r, -1)
            offsets = pa.array(np.arange(r + 1, dtype=np.int32) * a.shape[1])
            arrays.append(pa.ListArray.from_arrays(offsets, pa.array(a.reshape(-1))))
        else:
            arrays.append(pa.nulls(r, pa.list_(pa.float64())))
    return pa.Table.from_arrays(arrays, schema=SCHEMA)


class SignalsFile:
    """signals.parquet at ``path`` and its pending parts (module docstring)."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.parts = self.path.with_name(".signals-parts")
        self.pending: dict[str, Path] = {}  # case hash -> its part, not yet in the file
        self._cleaned = False

    def add(self, case_hash: str, signals: Mapping[str, Any] | None) -> None:
        """Record a case's signals (None: the case has none, an error row); replaces what
        the case had.

        Parameters
        ----------
        case_hash : str
            The case.
        signals : mapping or None
            Its signals ``{"t": (r,), key: (r, k)}``.
        """
        if not self._cleaned:  # parts a killed campaign left
            shutil.rmtree(self.parts, ignore_errors=True)
            self._cleaned = True
        old = self.pending.pop(case_hash, None)
        if old is not None:
            old.unlink(missing_ok=True)
        if signals is None:
            self.pending[case_hash] = self.parts / "none"  # replaces the file's rows by none
            return
        self.parts.mkdir(exist_ok=True)
        part = self.parts / f"{case_hash}.parquet"
        pq.write_table(signal_rows(-1, case_hash, signals), part)
        self.pending[case_hash] = part

    def write(self, cases: Mapping[str, int]) -> None:
        """Rewrite the file with the signals of the rows ``cases`` (case hash -> case number):
        the file's own rows of those not pending, then the pending parts; atomically."""
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        hashes = pa.array(list(cases), pa.string())
        numbers = np.fromiter(cases.values(), dtype=np.int64, count=len(cases))
        try:
            with pq.ParquetWriter(tmp, SCHEMA) as writer:
                for batch in self._old_batches():
                    # keep rows of cases that are still rows and were not run again
                    where = pc.index_in(batch.column("case_hash"), value_set=hashes)
                    keep = pc.and_(
                        pc.is_valid(where),
                        pc.invert(pc.is_in(batch.column("case_hash"),
                                           value_set=pa.array(list(self.pending), pa.string()))),
                    )  # fmt: skip
                    batch = batch.filter(keep)
                    if batch.num_rows:
                        idx = pc.index_in(batch.column("case_hash"), value_set=hashes)
                        case = pa.array(numbers[idx.to_numpy(zero_copy_only=False)])
                        writer.write_table(_with_case(batch, case))
                for case_hash, part in self.pending.items():
                    if case_hash in cases and part.suffix == ".parquet":
                        table = pq.read_table(part, schema=SCHEMA)
                        case = pa.array(np.full(table.num_rows, cases[case_hash], np.int64))
                        writer.write_table(_with_case(table, case))
            os.replace(tmp, self.path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        for part in self.pending.values():
            part.unlink(missing_ok=True)
        self.pending.clear()
        try:
            self.parts.rmdir()
        except OSError:
            pass

    def _old_batches(self):
        """The earlier file's rows in batches (nothing without a readable file of this
        schema)."""
        try:
            source = pq.ParquetFile(self.path)
        except (OSError, pa.ArrowException):
            return
        if not set(SIGNAL_TYPES) <= set(source.schema_arrow.names):
            return
        for batch in source.iter_batches(batch_size=65_536, columns=list(SIGNAL_TYPES)):
            yield pa.Table.from_batches([batch]).cast(SCHEMA)


def _with_case(table: pa.Table, case: pa.Array) -> pa.Table:
    return table.set_column(0, pa.field("case", pa.int64()), case)
