"""Simulates an FMU with FMPy on a given grid and writes CSV (time first), for fmucal's
cross-checks. Exits with status 3 and prints the problems if FMPy's validation fails.
FMPy's recorder keeps every row it samples: on the grid, at input events in Co-Simulation,
and at the last successful time of a terminated Co-Simulation; all are written.
FMI 1.0, 2.0 and 3.0 FMUs alike; --interface must name an interface the FMU offers (an FMI 1.0
FMU offers one), else it exits with status 2. FMI 3.0 arrays: a start value of several numbers
separated by spaces (--set "k=1 2 3") sets an array, and an array output NAME is written as the
columns NAME[1], NAME[2], ... (the element names of FMI's structured naming convention).
String and Binary start values: --set-text NAME=VALUE passes VALUE to FMPy unconverted (FMPy
reads a Binary value as hexadecimal, two digits per byte, as FMI 3.0 writes Binary starts)."""
import argparse
import sys

import numpy as np
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--fmu", required=True)
    p.add_argument("--interface", choices=["me", "cs"], required=True)
    p.add_argument("--rtol", type=float, default=1e-8)
    p.add_argument("--interval", type=float, required=True)
    p.add_argument("--stop", type=float, required=True)
    p.add_argument("--input", help="CSV with a time column and one column per input")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="start value (repeatable); several space-separated numbers set an array")
    p.add_argument("--set-text", action="append", default=[], metavar="NAME=VALUE",
                   help="start value of a String or Binary (hex) variable, passed as text (repeatable)")
    p.add_argument("--output", action="append", default=[],
                   help="variable to record (repeatable); none: FMPy's default outputs")
    p.add_argument("--out", required=True)
    a = p.parse_args()

    problems = validate_fmu(a.fmu)
    if problems:
        print("FMPy validation failed:", *problems, sep="\n  ", file=sys.stderr)
        sys.exit(3)
    md = read_model_description(a.fmu, validate=True)
    # An FMI 1.0 FMU offers one interface (Model Exchange, or Co-Simulation when it has an
    # Implementation element); 2.0 and 3.0 FMUs may offer both.
    offered = md.modelExchange if a.interface == "me" else md.coSimulation
    if offered is None:
        print(f"the FMU (FMI {md.fmiVersion}) does not offer "
              f"{'Model Exchange' if a.interface == 'me' else 'Co-Simulation'}", file=sys.stderr)
        sys.exit(2)

    signals = None
    if a.input:
        raw = np.genfromtxt(a.input, delimiter=",", names=True, deletechars="")
        signals = np.array(raw, dtype=[(n, np.float64) for n in raw.dtype.names])
    start_values = {}
    for item in a.set:
        name, value = item.split("=", 1)
        numbers = [float(v) for v in value.split()]
        start_values[name] = numbers[0] if len(numbers) == 1 else numbers
    for item in a.set_text:
        name, value = item.split("=", 1)
        start_values[name] = value
    result = simulate_fmu(
        a.fmu,
        fmi_type="ModelExchange" if a.interface == "me" else "CoSimulation",
        start_time=0.0,
        stop_time=a.stop,
        relative_tolerance=a.rtol,
        output_interval=a.interval,
        input=signals,
        start_values=start_values,
        output=a.output or None,
        record_events=False,
        validate=True,
    )
    header, columns = [], []
    recorded = a.output or [n for n in result.dtype.names if n != "time"]
    for name in ["time"] + recorded:
        values = np.asarray(result[name], dtype=np.float64)
        if values.ndim == 1:
            header.append(name)
            columns.append(values)
        else:  # an FMI 3.0 array: one column per element, row-major
            values = values.reshape(values.shape[0], -1)
            header += [f"{name}[{k + 1}]" for k in range(values.shape[1])]
            columns += list(values.T)
    np.savetxt(a.out, np.column_stack(columns), delimiter=",", header=",".join(header), comments="", fmt="%.17g")


if __name__ == "__main__":
    main()
