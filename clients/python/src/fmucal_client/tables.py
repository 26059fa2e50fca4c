"""Measurement tables read as the CLI reads them, to send with a job.

- CSV: a header row, separated by ``,``, ``;`` or tab (whichever the header holds most of
  outside quotes), the time column anywhere (named by ``time_column``), cells trimmed, an
  empty cell a missing value (NaN), numbers in Rust's syntax (``1e-3``, ``.5``, ``inf``,
  ``NaN``; no ``1_000``; a decimal comma where commas do not separate), blank lines skipped.
- MATLAB v5 ``.mat`` (any case of the extension): the variable ``time_column`` is the time and
  every other real double, single, int32 or int64 array is a column, in the file's order and
  its storage (column-major) order; other arrays (complex, character, logical, structs, other
  integer classes) are left out. Read with SciPy (``pip install scipy``).
- MATLAB v4 ``.mat``: a Modelica result file as Dymola (``dsres.mat``) and OpenModelica
  (``_res.mat``) write it, every variable of ``name`` a column, resolved through ``dataInfo``
  (parameters of ``data_1`` repeated at every time, aliases and negated aliases); a v4 file
  without ``Aclass`` is read as a v5 one is. Read with SciPy.

The time column is ``time_column``, or, when no column has that name and exactly one has it
in another case (Dymola's ``Time``), that one.

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


def _cell(text: str, decimal_comma: bool = False) -> float | None:
    """A cell's number; empty is NaN (missing); ``None`` if it is not a number."""
    if text == "":
        return math.nan
    if _NUMBER.fullmatch(text):
        return float(text)
    if decimal_comma and text.count(",") == 1 and "." not in text and _NUMBER.fullmatch(text.replace(",", ".")):
        return float(text.replace(",", "."))
    return None


def _delimiter(header: str) -> str:
    """``,``, ``;`` or tab: whichever ``header`` holds most of outside quotes (``,`` if none)."""
    counts = {",": 0, ";": 0, "\t": 0}
    quoted = False
    for c in header:
        if c == '"':
            quoted = not quoted
        elif c in counts and not quoted:
            counts[c] += 1
    best = max(counts, key=lambda c: counts[c])  # ties: the first, as the CLI
    return best if counts[best] else ","


def _edit_distance(a: str, b: str) -> int:
    row = list(range(len(b) + 1))
    for i, ca in enumerate(a):
        diagonal, row[0] = row[0], i + 1
        for j, cb in enumerate(b):
            diagonal, row[j + 1] = row[j + 1], min(row[j + 1] + 1, row[j] + 1, diagonal + (ca != cb))
    return row[len(b)]


def closest(name: str, names: list[str], n: int = 5) -> list[str]:
    """Up to ``n`` of ``names`` closest to ``name`` by edit distance (case-insensitive, over the
    first 64 characters), ties in their order: as the CLI's hints."""
    key = name[:64].lower()
    return [c for _, _, c in sorted((_edit_distance(key, c[:64].lower()), i, c) for i, c in enumerate(names))][:n]


def _find_time(names: list[str], time_column: str, what: str = "column") -> int:
    """The position of the time column among ``names`` (see the module docs)."""
    if time_column in names:
        return names.index(time_column)
    alike = [i for i, h in enumerate(names) if h.lower() == time_column.lower()]
    if len(alike) == 1:
        return alike[0]
    if alike:
        hint = f"; did you mean {' or '.join(quote(names[i]) for i in alike[:5])}?"
    else:
        near = closest(time_column, names)
        hint = f"; the closest: {', '.join(quote(c) for c in near)}" if near else ""
    raise _ReadError(f"no {what} named {quote(time_column)}{hint}", 1 if what == "column" else None)


def read_csv(path: Path, time_column: str) -> Table:
    """Reads a CSV file with a header row (see the module docs)."""
    try:
        # utf-8-sig: a byte-order mark (as Excel writes) is skipped, as the CLI's reader does.
        with path.open(newline="", encoding="utf-8-sig") as f:
            separator = _delimiter(f.readline())
            f.seek(0)
            rows = [row for row in csv.reader(f, delimiter=separator) if row]
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise _ReadError(str(e)) from e
    headers = [h.strip(_SPACE) for h in rows[0]] if rows else []
    t = _find_time(headers, time_column)
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
            v = _cell(text, separator != ",")
            if v is None:
                raise _ReadError(f"column {quote(name)}: {quote(text)} is not a number", line)
            column.append(v)
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
        if major == 0:
            return _read_mat4(loadmat(str(path), chars_as_strings=False), time_column)
        if major != 1:
            raise ValueError("version 7.3 (HDF5)")
        arrays = loadmat(str(path), mat_dtype=True)
    except OSError as e:
        raise _ReadError(str(e)) from e
    except _ReadError:
        raise
    except Exception as e:  # SciPy raises several kinds for files it cannot parse.
        raise _ReadError(f"not a MATLAB v4 or v5 file: {e}") from e
    names = [n for n in arrays if n not in ("__header__", "__version__", "__globals__")]
    time_name = names[_find_time(names, time_column, "variable")]
    time = _real_values(arrays[time_name])
    if time is None:
        raise _ReadError(f"{quote(time_name)} is not a real numeric array")
    if not time:
        raise _ReadError("no data rows")
    columns = []
    for name, array in arrays.items():
        if name in ("__header__", "__version__", "__globals__") or name == time_name:
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


def _read_mat4(arrays: dict, time_column: str) -> Table:
    """A MATLAB v4 file as SciPy reads it: a Modelica result file, or plain matrices."""
    if "Aclass" not in arrays:
        numeric = {k: v for k, v in arrays.items() if not k.startswith("__") and _real_values(v) is not None}
        names = list(numeric)
        time_name = names[_find_time(names, time_column, "variable")]
        columns = [(n, _real_values(v) or []) for n, v in numeric.items() if n != time_name]
        return Table(_real_values(numeric[time_name]) or [], columns)

    def strings(a: object, transposed: bool) -> list[str]:
        rows = a.T if transposed else a  # type: ignore[attr-defined]
        return ["".join(r).rstrip(" \0") for r in rows]

    aclass = strings(arrays["Aclass"], False)
    if not aclass or aclass[0] != "Atrajectory":
        raise _ReadError("not a Modelica result file: Aclass does not start with \"Atrajectory\"")
    transposed = len(aclass) > 3 and aclass[3] == "binTrans"
    for needed in ("name", "dataInfo", "data_2"):
        if needed not in arrays:
            raise _ReadError(f"invalid result file: no {needed} matrix")
    fix = (lambda a: a.T) if transposed else (lambda a: a)
    names = strings(arrays["name"], transposed)
    info = fix(arrays["dataInfo"])
    data_2 = fix(arrays["data_2"]).astype(float)
    data_1 = fix(arrays["data_1"]).astype(float) if "data_1" in arrays else None
    if info.shape[0] != len(names) or info.shape[1] < 2:
        raise _ReadError(f"invalid result file: dataInfo is {info.shape[0]}×{info.shape[1]} for {len(names)} names")
    times = data_2.shape[0]
    if times == 0:
        raise _ReadError("no data rows: data_2 holds no time points")

    def values(j: int) -> list[float]:
        block, index = int(info[j, 0]), int(info[j, 1])
        matrix = data_1 if block == 1 else data_2 if block in (0, 2) else None
        if matrix is None or not 1 <= abs(index) <= matrix.shape[1] or matrix.shape[0] == 0:
            raise _ReadError(f"invalid result file: dataInfo of {quote(names[j])} points outside the data")
        sign = -1.0 if index < 0 else 1.0
        if block == 1:
            return [sign * float(matrix[0, abs(index) - 1])] * times
        return [sign * float(v) for v in matrix[:, abs(index) - 1]]

    t = _find_time(names, time_column, "variable")
    seen: set[str] = set()
    columns = []
    for j, name in enumerate(names):
        if name in seen:
            continue
        seen.add(name)
        if j != t:
            columns.append((name, values(j)))
    return Table(values(t), columns)
