"""Writes the data fixtures of tests/data/ (run from anywhere; numpy only).

Each file is laid out as Dymola writes `dsres.mat` and OpenModelica `_res.mat`: `Aclass`
(`Atrajectory`, `1.1`, an empty row, `binTrans` or `binNormal`), `name` and `description`
(char matrices), `dataInfo` (int32: data matrix, 1-based column, negative for a negated alias,
interpolation, extrapolation), the parameters in `data_1` (two time points, start and end) and
the trajectories in `data_2`, both with time first.

The data are the `decay` example's: x' = -k x, x(0) = 1, k = 1.7, sampled every 0.1 s to 2 s.
- decay_dymola.mat: binTrans, float32 data, time named `Time` (dataInfo matrix 0, Dymola's way)
- decay_om.mat: binTrans, float64 data, time named `time` (dataInfo matrix 2)
- decay_normal.mat: binNormal (matrices not transposed), float64

and the same data as CSV: decay_semicolon.csv (`;`, decimal commas as a spreadsheet in a
German locale writes them), decay_tab.csv (tab) and decay_Time.csv (`,`, time headed `Time`).
"""

import os
import struct

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def matrix(name, values, text=False):
    """One little-endian v4 matrix: header MOPT, mrows, ncols, imagf, namlen; name; data."""
    values = np.asarray(values)
    if values.ndim == 1:
        values = values.reshape(-1, 1)
    precision = {np.dtype("float64"): 0, np.dtype("float32"): 1, np.dtype("int32"): 2, np.dtype("uint8"): 5}
    mopt = 0 * 1000 + 0 * 100 + precision[values.dtype] * 10 + (1 if text else 0)
    rows, cols = values.shape
    header = struct.pack("<5i", mopt, rows, cols, 0, len(name) + 1)
    return header + name.encode() + b"\0" + values.tobytes(order="F")


def chars(strings, transposed):
    """A char matrix (uint8), one string per row, padded with spaces; transposed: per column."""
    width = max(len(s) for s in strings)
    m = np.array([list(s.ljust(width).encode()) for s in strings], dtype=np.uint8).reshape(len(strings), width)
    return m.T if transposed else m


def write(path, time_name, time_block, dtype, transposed):
    k = 1.7
    t = np.round(np.arange(21) * 0.1, 10)
    x = np.exp(-k * t)
    # name, description, dataInfo rows (matrix, column, interpolation, extrapolation)
    variables = [
        (time_name, "Simulation time [s]", [time_block, 1, 0, -1]),
        ("k", "decay rate [1/s]", [1, 2, 0, 0]),
        ("x", "state", [2, 2, 0, -1]),
        ("der(x)", "der(state)", [2, 3, 0, -1]),
        ("xAlias", "an alias of x", [2, 2, 0, -1]),
        ("minusX", "a negated alias of x", [2, -2, 0, -1]),
        ("kAlias", "a negated alias of k", [1, -2, 0, 0]),
    ]
    names = [v[0] for v in variables]
    descriptions = [v[1] for v in variables]
    info = np.array([v[2] for v in variables], dtype=np.int32)
    data_1 = np.array([[t[0], k], [t[-1], k]], dtype=dtype)  # rows: time points
    data_2 = np.column_stack([t, x, -k * x]).astype(dtype)
    aclass = ["Atrajectory", "1.1", "", "binTrans" if transposed else "binNormal"]
    out = b"".join(
        [
            matrix("Aclass", chars(aclass, False), text=True),
            matrix("name", chars(names, transposed), text=True),
            matrix("description", chars(descriptions, transposed), text=True),
            matrix("dataInfo", info.T if transposed else info),
            matrix("data_1", data_1.T if transposed else data_1),
            matrix("data_2", data_2.T if transposed else data_2),
        ]
    )
    with open(os.path.join(HERE, path), "wb") as f:
        f.write(out)


def write_csv(path, separator, time_name, decimal_comma=False):
    t = np.round(np.arange(21) * 0.1, 10)
    x = np.exp(-1.7 * t)
    number = (lambda v: repr(float(v)).replace(".", ",")) if decimal_comma else (lambda v: repr(float(v)))
    lines = [separator.join([time_name, "x"])] + [separator.join([number(a), number(b)]) for a, b in zip(t, x)]
    with open(os.path.join(HERE, path), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    write_csv("decay_semicolon.csv", ";", "time", decimal_comma=True)
    write_csv("decay_tab.csv", "\t", "time")
    write_csv("decay_Time.csv", ",", "Time")
    write("decay_dymola.mat", "Time", 0, np.float32, True)
    write("decay_om.mat", "time", 2, np.float64, True)
    write("decay_normal.mat", "time", 2, np.float64, False)
