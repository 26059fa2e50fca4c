"""Generates the Furuta measurements of fmucal's first example (Andersson et al. 2012, 6.1).

Simulates the project's Furuta FMU with `fmucal simulate` (friction 0.010 on the arm and 0.0010
on the pendulum, the values the paper recovered), from the pendulum at 1 rad and a motor torque
profile that moves the arm both ways, for 40 s sampled every 0.01 s; adds white noise
(seeded) to both angles; writes furuta_data.csv (time, phi, theta, u) and FurutaData.mat with
the variables `time`, `phi` and `theta` (and `u`), as the paper loads it.

Usage: python generate_data.py FMUCAL_BINARY   (bash examples/furuta/generate.sh does it all)
"""
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.io

SEED = 2012
NOISE_STD = 0.005  # rad
ARM_FRICTION, PENDULUM_FRICTION = 0.010, 0.0010

here = Path(__file__).resolve().parent
fmucal = sys.argv[1]
t = np.round(np.arange(0, 40.0 + 1e-9, 0.01), 10)
# Torque: a slow sine plus two pulses, so both joints keep moving.
u = 0.03 * np.sin(0.4 * t) + np.where((t >= 5) & (t < 6), 0.08, 0.0) - np.where((t >= 22) & (t < 23), 0.08, 0.0)

with tempfile.TemporaryDirectory() as tmp:
    inp = Path(tmp) / "u.csv"
    np.savetxt(inp, np.column_stack([t, u]), delimiter=",", header="time,u", comments="", fmt="%.17g")
    out = Path(tmp) / "sim.csv"
    subprocess.run([fmucal, "simulate", "example:furuta", "--set", f"armFriction={ARM_FRICTION}",
                    "--set", f"pendulumFriction={PENDULUM_FRICTION}", "--input", str(inp), "--stop-time", "40",
                    "--output-interval", "0.01", "--tolerance", "1e-9", "-o", str(out)], check=True)
    sim = np.genfromtxt(out, delimiter=",", names=True, deletechars="")

rng = np.random.RandomState(SEED)
phi = sim["armJoint.phi"] + rng.normal(0, NOISE_STD, len(t))
theta = sim["pendulumJoint.phi"] + rng.normal(0, NOISE_STD, len(t))
np.savetxt(here / "furuta_data.csv", np.column_stack([t, phi, theta, u]), delimiter=",",
           header="time,phi,theta,u", comments="", fmt="%.10g")
scipy.io.savemat(here / "FurutaData.mat", {"time": t.reshape(-1, 1), "phi": phi.reshape(-1, 1),
                                           "theta": theta.reshape(-1, 1), "u": u.reshape(-1, 1)})
print(f"wrote {here / 'furuta_data.csv'} and {here / 'FurutaData.mat'} ({len(t)} samples)")
