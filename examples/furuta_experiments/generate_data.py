"""Generates the measurements of fmucal's multi-experiment example: the Furuta pendulum of the
paper's section 6.1 (viscous friction 0.010 on the arm and 0.0010 on the pendulum) in three
experiments that differ in motor torque profile and in the pendulum's initial angle:

- `sine`:   a slow sine torque plus a pulse, pendulum released at 1.0 rad;
- `steps`:  torque steps of alternating sign, pendulum released at 0.5 rad;
- `chirp`:  a sine of rising frequency, pendulum released at -0.7 rad (held out for validation).

Each is simulated with `fmucal simulate` for 20 s sampled every 0.01 s; white noise (seeded)
is added to both angles; each is written to NAME.csv (time, phi, theta, u).

Usage: python generate_data.py FMUCAL_BINARY   (bash examples/furuta_experiments/generate.sh)
"""
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

SEED = 2026
NOISE_STD = 0.005  # rad
ARM_FRICTION, PENDULUM_FRICTION = 0.010, 0.0010
STOP = 20.0

here = Path(__file__).resolve().parent
fmucal = sys.argv[1]
t = np.round(np.arange(0, STOP + 1e-9, 0.01), 10)
EXPERIMENTS = {
    "sine": (1.0, 0.03 * np.sin(0.4 * t) + np.where((t >= 5) & (t < 6), 0.08, 0.0)),
    "steps": (0.5, 0.05 * np.sign(np.sin(2 * np.pi * t / 8.0 + 0.1))),
    "chirp": (-0.7, 0.04 * np.sin(2 * np.pi * (0.05 + 0.02 * t) * t)),
}

rng = np.random.RandomState(SEED)
for name, (theta0, u) in EXPERIMENTS.items():
    with tempfile.TemporaryDirectory() as tmp:
        inp = Path(tmp) / "u.csv"
        np.savetxt(inp, np.column_stack([t, u]), delimiter=",", header="time,u", comments="", fmt="%.17g")
        out = Path(tmp) / "sim.csv"
        subprocess.run([fmucal, "simulate", "example:furuta", "--set", f"armFriction={ARM_FRICTION}",
                        "--set", f"pendulumFriction={PENDULUM_FRICTION}", "--set", f"pendulumJoint.phi={theta0}",
                        "--input", str(inp), "--stop-time", str(STOP), "--output-interval", "0.01",
                        "--tolerance", "1e-9", "-o", str(out)], check=True)
        sim = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    phi = sim["armJoint.phi"] + rng.normal(0, NOISE_STD, len(t))
    theta = sim["pendulumJoint.phi"] + rng.normal(0, NOISE_STD, len(t))
    np.savetxt(here / f"{name}.csv", np.column_stack([t, phi, theta, u]), delimiter=",",
               header="time,phi,theta,u", comments="", fmt="%.10g")
    print(f"wrote {here / (name + '.csv')} ({len(t)} samples, pendulum from {theta0} rad)")
