"""FMPy on an FMU written by `fmucal export` (run by tests/export.rs).

Usage: exported.py CORRECTED.fmu STRONGER.fmu FMUCAL_ME.csv FMUCAL_CS.csv [OTHER.fmu ...]

- validate_fmu finds no problem in the description of CORRECTED.fmu and of each OTHER.fmu;
- FMPy simulates it in Model Exchange and in Co-Simulation (rtol 1e-8, output every 0.01 s,
  no inputs) and matches fmucal's CSVs within 1e-4 of each output's range;
- setting the effect parameter `effects[0].force` to 0.2 through start_values gives the
  trajectory of STRONGER.fmu, exported from the job with that start.
"""
import sys

import numpy as np
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

corrected, stronger, me_csv, cs_csv = sys.argv[1:5]

for path in [corrected] + sys.argv[5:]:
    problems = validate_fmu(path)
    if problems:
        sys.exit(f"validate_fmu {path}: " + "; ".join(str(p) for p in problems))
print("valid: no problem")

settings = dict(start_time=0.0, stop_time=10.0, output_interval=0.01, relative_tolerance=1e-8,
                output=["mass.x", "mass.v"])
for fmi_type, path in [("ModelExchange", me_csv), ("CoSimulation", cs_csv)]:
    r = simulate_fmu(corrected, fmi_type=fmi_type, **settings)
    ref = np.genfromtxt(path, delimiter=",", names=True)
    for name, col in [("mass.x", "massx"), ("mass.v", "massv")]:
        scale = max(np.ptp(ref[col]), 1e-12)
        err = np.max(np.abs(np.interp(ref["time"], r["time"], r[name]) - ref[col])) / scale
        print(f"{fmi_type} {name}: {err:.2e} of its range")
        if not err < 1e-4:
            sys.exit(f"{fmi_type} {name}: FMPy and fmucal differ by {err:.2e} of the range")

a = simulate_fmu(corrected, fmi_type="ModelExchange", start_values={"effects[0].force": 0.2}, **settings)
b = simulate_fmu(stronger, fmi_type="ModelExchange", **settings)
base = simulate_fmu(corrected, fmi_type="ModelExchange", **settings)
# Rows at events differ between runs with other parameters: compare on the output grid.
grid = np.linspace(0.0, 10.0, 1001)
x = lambda r: np.interp(grid, r["time"], r["mass.x"])
d = np.max(np.abs(x(a) - x(b)))
moved = np.max(np.abs(x(a) - x(base)))
if not (d <= 1e-12 and moved > 1e-3):
    sys.exit(f"start value: differs from the job by {d:.2e}, moves the motion by {moved:.2e}")
print("start value: same as the job")
