"""Measurement tables read as the CLI reads them, to send with a job.

- CSV: a header row, the time column anywhere (named by ``time_column``), cells trimmed, an
  empty cell a missing value (NaN), numbers in Rust's syntax (``1e-3``, ``.5``, ``inf``,
  ``NaN``; no ``1_000``), blank lines skipped.
- MATLAB v5 ``.mat`` (any case of the extension): the variable ``time_column`` is the time and
  every other real double, single, int32 or int64 array is a column, in the file's order and
  its storage (column-major) order; other arrays (complex, character, logical, structs, other
  integer classes) are left out. Read with SciPy (``pip install scipy``).

Errors name the field where the file was given (``data`` or ``experiments[K].data``) and, for
CSV, the line, with the CLI's wording.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

from .errors import JobFileError
from .job import DataRef, JobSpec, quote

# Rust's f64 syntax: no underscores, no surrounding spaces (cells are trimmed first).
_NUMBER = re.compile(r"[+-]?(?:inf|infinity|nan|(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?)", re.IGNORECASE)
# What the CLI's CSV reader trims from headers and cells.
_SPACE = " \t\r\n\x0c"
# The MATLAB classes the CLI reads as columns, by the dtype SciPy gives them.
_REAL_KINDS = ("float64", "float32", "int32", "int64")


@dataclass(frozen=True)
class Table:
    """A time column and named columns of the same length; NaN marks a missing value."""

    time: list[float]
    columns: list[tuple[str, list[float]]]


class _ReadError(Exception):
    """A file that cannot be read, with the CSV line at fault if there is one."""

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(f"line {line}: {message}" if line is not None else message)


def read_all(spec: JobSpec) -> list[Table]:
    """The table of each experiment of ``spec`` (one for a job without experiments), read once
    per file and time column.

    Raises:
        JobFileError: naming ``data`` or ``experiments[K].data``.
    """
    views: list[tuple[str, DataRef]] = []
    if not spec.experiments:
        views.append(("data", spec.data))
    for k, e in enumerate(spec.experiments):
        views.append((f"experiments[{k}].data" if e.data is not None else "data", e.data or spec.data))
    read: dict[tuple[str, str], Table] = {}
    tables = []
    for k, (field, data) in enumerate(views):
        if data.path is None:
            where = f"experiments[{k}].data" if spec.experiments else "data"
            raise JobFileError(where, "give the path of the measurements")
        key = (str(data.path), data.time_column)
        if key not in read:
            read[key] = read_table(Path(data.path), data.time_column, field)
        tables.append(read[key])
    return tables


def read_table(path: Path, time_column: str, field: str = "data") -> Table:
    """Reads ``path`` (``.mat``, else CSV) with its time column named ``time_column``.

    Raises:
        JobFileError: ``field: cannot read PATH: [line N: ]why``.
    """
    try:
        if path.suffix.lower() == ".mat":
            return read_mat(path, time_column)
        return read_csv(path, time_column)
    except _ReadError as e:
        raise JobFileError(field, f"cannot read {path}: {e}") from None


def _cell(text: str) -> float | None:
    """A cell's number; empty is NaN (missing); ``None`` if it is not a number."""
    if text == "":
        return math.nan
    return float(text) if _NUMBER.fullmatch(text) else None


def read_csv(path: Path, time_column: str) -> Table:
    """Reads a CSV file with a header row (see the module docs)."""
    try:
        # utf-8-sig: a byte-order mark (as Excel writes) is skipped, as the CLI's reader does.
        with path.open(newline="", encoding="utf-8-sig") as f:
            rows = [row for row in csv.reader(f) if row]
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise _ReadError(str(e)) from e
    headers = [h.strip(_SPACE) for h in rows[0]] if rows else []
    if time_column not in headers:
        raise _ReadError(f"no column named {quote(time_column)}", 1)
    for i, h in enumerate(headers):
        if h in headers[:i]:
            raise _ReadError(f"column {quote(h)} appears twice", 1)
    values: list[list[float]] = [[] for _ in headers]
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(headers):
            missing = f", column {quote(headers[len(row)])} is missing" if len(row) < len(headers) else ""
            raise _ReadError(f"{len(row)} cells for {len(headers)} columns{missing}", line)
        for cell, name, column in zip(row, headers, values):
            text = cell.strip(_SPACE)
            v = _cell(text)
            if v is None:
                raise _ReadError(f"column {quote(name)}: {quote(text)} is not a number", line)
            column.append(v)
    t = headers.index(time_column)
    time = values.pop(t)
    if not time:
        raise _ReadError("no data rows")
    names = [h for i, h in enumerate(headers) if i != t]
    return Table(time, list(zip(names, values)))


def read_mat(path: Path, time_column: str) -> Table:
    """Reads a MATLAB v5 file with SciPy (see the module docs)."""
    try:
        from scipy.io import loadmat, matlab
    except ImportError:
        raise _ReadError("reading MATLAB .mat files needs SciPy (pip install scipy), or give the data as CSV") from None
    try:
        major, _ = matlab.matfile_version(str(path))
        if major != 1:
            raise ValueError(f"version {'7.3 (HDF5)' if major == 2 else 4}")
        arrays = loadmat(str(path), mat_dtype=True)
    except OSError as e:
        raise _ReadError(str(e)) from e
    except Exception as e:  # SciPy raises several kinds for files it cannot parse.
        raise _ReadError(f"not a MATLAB v5 file: {e}") from e
    if time_column not in arrays:
        raise _ReadError(f"no variable named {quote(time_column)}")
    time = _real_values(arrays[time_column])
    if time is None:
        raise _ReadError(f"{quote(time_column)} is not a real numeric array")
    if not time:
        raise _ReadError("no data rows")
    columns = []
    for name, array in arrays.items():
        if name in ("__header__", "__version__", "__globals__") or name == time_column:
            continue
        values = _real_values(array)
        if values is not None:
            columns.append((name, values))
    return Table(time, columns)


def _real_values(array: object) -> list[float] | None:
    """The values of a real double, single, int32 or int64 array in storage order, else None."""
    dtype = getattr(array, "dtype", None)
    if dtype is None or dtype.name not in _REAL_KINDS:
        return None
    return [float(v) for v in array.ravel(order="F")]  # type: ignore[attr-defined]
