"""An end-effector reference from a CSV file (``reference.ee_file``, docs/cli.md)."""

from __future__ import annotations

from pathlib import Path

from ..errors import ParameterError, ScenarioError, not_a_file
from .trajectory import ReferenceData


def read_reference_csv(path: str | Path, n_components: int) -> ReferenceData:
    """An end-effector reference from a CSV file: a header row ``t, <one name per task
    component>``, then one row per sample, times [s] increasing (docs/cli.md, ``ee_file``).

    Messages name the file and the line and say what was expected there; they never quote the
    file's content (a file that is no CSV at all, say ``/etc/passwd``, is not echoed).

    Raises
    ------
    ScenarioError
        Missing file, a folder or another file that is not regular (a FIFO, a device), an
        unreadable or non-UTF-8 file, a header whose first column is not ``t`` or with the
        wrong number of columns, a row with the wrong number of values or a non-number, times
        that do not increase.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    n_components : int
        Task components (columns after ``t``).

    Returns
    -------
    ReferenceData
        The samples.
    """
    path = Path(path)
    where = f"reference.ee_file {str(path)!r}"
    if not path.is_file():
        raise ScenarioError(f"{where} {not_a_file(path)}")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as exc:
        bad_line = path.read_bytes()[: exc.start].count(b"\n") + 1
        raise ScenarioError(
            f"{where}, line {bad_line}: not UTF-8 text; expected a CSV file"
        ) from None
    except OSError as exc:
        raise ScenarioError(f"{where}: cannot read: {exc.strerror or type(exc).__name__}") from None
    rows = [(i + 1, line) for i, line in enumerate(lines) if line.strip()]
    if not rows:
        raise ScenarioError(f"{where}: empty; expected a header row 't, ...' and samples")
    columns = n_components + 1
    head_line, head = rows[0]
    header = [h.strip() for h in head.split(",")]
    if len(header) != columns or header[0] != "t":
        found = (
            f"has {len(header)} column(s)" if len(header) != columns else "does not start with 't'"
        )
        raise ScenarioError(
            f"{where}, line {head_line}: the header row {found}; expected 't' and "
            f"{n_components} column names (one per task component), comma-separated"
        )
    times, values = [], []
    for lineno, line in rows[1:]:
        cells = line.split(",")
        if len(cells) != columns:
            raise ScenarioError(
                f"{where}, line {lineno}: {len(cells)} values, expected {columns} "
                "(t and one per task component)"
            )
        try:
            numbers = [float(c) for c in cells]
        except ValueError:
            bad = next(i for i, c in enumerate(cells) if not _is_float(c))
            raise ScenarioError(
                f"{where}, line {lineno}: not numbers (column {bad + 1}: expected a number)"
            ) from None
        times.append(numbers[0])
        values.append(tuple(numbers[1:]))
    try:
        return ReferenceData(tuple(times), tuple(values), "spline", str(path))
    except ParameterError as exc:
        raise ScenarioError(f"reference.ee_file {exc}") from None


def _is_float(text: str) -> bool:
    """Whether ``float(text)`` reads it."""
    try:
        float(text)
    except ValueError:
        return False
    return True
