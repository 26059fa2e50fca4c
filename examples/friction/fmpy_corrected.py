"""Simulates the corrected model `fmucal diagnose` (or `fmucal export`) wrote, with FMPy alone,
against the measurements: once as exported (the named friction inside) and once with the
friction's strength set to 0 through FMPy's start values (the calibrated model without the
effect). Prints the RMS error of each over the validation window and draws both.

Usage: python fmpy_corrected.py diagnosis/corrected.fmu data.csv corrected.png
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from fmpy import simulate_fmu

fmu, data_csv, png = sys.argv[1:4]
data = np.genfromtxt(data_csv, delimiter=",", names=True)
runs = {
    "corrected.fmu (friction inside)": simulate_fmu(fmu, stop_time=20.0, output_interval=0.01, output=["mass.x"]),
    "same, effects[0].force = 0": simulate_fmu(
        fmu, stop_time=20.0, output_interval=0.01, output=["mass.x"], start_values={"effects[0].force": 0.0}
    ),
}
held_out = data["time"] > 15.0
fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
top.plot(data["time"], data["x"], ".", ms=2, color="0.5", label="measured x")
for label, r in runs.items():
    x = np.interp(data["time"], r["time"], r["mass.x"])
    rms = np.sqrt(np.mean((x[held_out] - data["x"][held_out]) ** 2))
    print(f"{label}: validation RMS {rms:.4g} m")
    top.plot(r["time"], r["mass.x"], label=f"{label}, validation RMS {rms:.2g} m")
    bottom.plot(data["time"], x - data["x"], lw=0.8, label=label)
for ax in (top, bottom):
    ax.axvspan(15.0, 20.0, color="0.92")
top.set_ylabel("mass.x [m]")
bottom.set_ylabel("simulated - measured [m]")
bottom.set_xlabel("time [s] (shaded: validation, never fitted)")
top.legend(fontsize=8)
top.set_title("FMPy simulating the FMU that fmucal diagnose wrote")
fig.tight_layout()
fig.savefig(png, dpi=110)
