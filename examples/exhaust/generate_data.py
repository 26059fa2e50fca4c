"""Generates the exhaust-pipe measurements of fmucal's second example (Andersson et al. 2012, 6.2).

30 minutes of plausible engine operation sampled every second drive the project's ExhaustPipe
FMU: a seeded load profile (load steps smoothed with a 20 s time constant, plus small
fluctuations) sets the inlet gas temperature and pressure, both turbine speeds and the outlet
pressure. The "true" wall capacities and conductances differ from the FMU's nominal values;
seeded white noise (0.2 K) is added to the outlet temperature. Writes exhaust_data.csv.

Usage: python generate_data.py FMUCAL_BINARY   (bash examples/exhaust/generate.sh does it all)
"""
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

SEED = 62
NOISE_STD = 0.2  # K
TRUE = {
    "leftVolume.wallCapacity": 4000.0,     # nominal 8000
    "leftVolume.wallConductance": 35.0,    # nominal 60
    "rightVolume.wallCapacity": 24000.0,   # nominal 12000
    "rightVolume.wallConductance": 150.0,  # nominal 80
}

here = Path(__file__).resolve().parent
fmucal = sys.argv[1]
rng = np.random.RandomState(SEED)
t = np.arange(0, 1801, 1.0)
# Engine load in [0.2, 1]: a new level every 60-180 s, smoothed, plus small fluctuations.
levels, k = np.empty_like(t), 0
while k < len(t):
    n = rng.randint(60, 180)
    levels[k:k + n] = rng.uniform(0.2, 1.0)
    k += n
load = np.empty_like(t)
load[0] = levels[0]
for i in range(1, len(t)):
    load[i] = load[i - 1] + (levels[i] - load[i - 1]) / 20.0
load = np.clip(load + rng.normal(0, 0.01, len(t)), 0.15, 1.05)

inputs = {
    "inlet.T": 560.0 + 300.0 * load,
    "inlet.p": 1.5e5 + 1.6e5 * load,
    "turbine1.w": 6000.0 + 5000.0 * load,
    "turbine2.w": 4000.0 + 3500.0 * load,
    "outlet.p": 1.02e5 + 0.08e5 * load,
}

with tempfile.TemporaryDirectory() as tmp:
    inp = Path(tmp) / "inputs.csv"
    names = list(inputs)
    np.savetxt(inp, np.column_stack([t] + [inputs[n] for n in names]), delimiter=",",
               header=",".join(["time"] + names), comments="", fmt="%.10g")
    out = Path(tmp) / "sim.csv"
    cmd = [fmucal, "simulate", "example:exhaust-pipe", "--input", str(inp), "--stop-time", "1800",
           "--output-interval", "1", "--tolerance", "1e-8", "-o", str(out)]
    for name, value in TRUE.items():
        cmd += ["--set", f"{name}={value}"]
    subprocess.run(cmd, check=True)
    sim = np.genfromtxt(out, delimiter=",", names=True, deletechars="")

measured = sim["outlet.T"] + rng.normal(0, NOISE_STD, len(t))
cols = [t, measured] + [inputs[n] for n in names]
np.savetxt(here / "exhaust_data.csv", np.column_stack(cols), delimiter=",",
           header=",".join(["time", "outlet_T"] + names), comments="", fmt="%.10g")
print(f"wrote {here / 'exhaust_data.csv'} ({len(t)} samples)")
