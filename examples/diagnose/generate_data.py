"""Generates the measurements of fmucal's discrepancy example: a Furuta pendulum test bench
whose pendulum joint has Coulomb friction (0.004 N·m) that the example model lacks.

The "bench" is FurutaHiddenCoulomb.fmu, the Furuta model built from the same C source with the
friction compiled in (models/build.rs); its description is the base model's, so nothing but the
data tells. It is simulated with `fmucal simulate` for 20 s from the pendulum at 1 rad, with a
motor torque of two pulses and a slow sine, sampled every 0.01 s; white noise (seeded, 0.005
rad) is added to both angles. Writes data.csv (time, phi, theta, u).

Usage: python generate_data.py FMUCAL_BINARY BENCH_FMU   (bash generate.sh does it all)
"""
import csv
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

SEED = 10
NOISE_STD = 0.005  # rad

here = Path(__file__).resolve().parent
fmucal, bench = sys.argv[1], sys.argv[2]
t = np.round(np.arange(0, 20.0 + 1e-9, 0.01), 10)
u = (
    0.03 * np.sin(0.5 * t)
    + np.where((t >= 2) & (t < 3), 0.08, 0.0)
    - np.where((t >= 9) & (t < 10), 0.08, 0.0)
)

with tempfile.TemporaryDirectory() as tmp:
    inp, out = Path(tmp) / "u.csv", Path(tmp) / "out.csv"
    np.savetxt(inp, np.column_stack([t, u]), delimiter=",", header="time,u", comments="", fmt="%.10g")
    subprocess.run(
        [fmucal, "simulate", bench, "--stop-time", "20", "--output-interval", "0.01", "--tolerance", "1e-10",
         "--input", str(inp), "--output", "armJoint.phi", "--output", "pendulumJoint.phi", "-o", str(out)],
        check=True,
    )
    sim = np.genfromtxt(out, delimiter=",", names=True)

rng = np.random.default_rng(SEED)
phi = sim["armJointphi"] + rng.normal(0.0, NOISE_STD, len(t))
theta = sim["pendulumJointphi"] + rng.normal(0.0, NOISE_STD, len(t))
with open(here / "data.csv", "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["time", "phi", "theta", "u"])
    for row in zip(t, phi, theta, u):
        w.writerow([f"{v:.10g}" for v in row])
