"""What a user of 2026 would otherwise write: calibrate the Furuta frictions from
examples/furuta/furuta_data.csv with FMPy simulating the same FMU and
scipy.optimize.minimize(method="Nelder-Mead"), from the same start, with the bounds enforced by
clipping and the paper's 1e3 scaling and tolerances (xatol 1e-3, fatol 1e-2). The FMU is
extracted and its description read once, as FMPy recommends for repeated simulations.
Prints JSON: wall time, evaluations, x_opt.

Usage: python bench/fmpy_scipy_furuta.py FURUTA.fmu   (bash bench/fmpy_scipy_furuta.sh)
"""
import json
import sys
import time
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from scipy.optimize import minimize

fmu = sys.argv[1]
data = np.genfromtxt(Path(__file__).resolve().parent.parent / "examples/furuta/furuta_data.csv", delimiter=",", names=True)
signals = np.array(list(zip(data["time"], data["u"])), dtype=[("time", np.float64), ("u", np.float64)])
lower, upper = np.array([0.0, 0.0]), np.array([22.0, 12.0])
evaluations = 0

start = time.perf_counter()
md = read_model_description(fmu)
unzipdir = extract(fmu)


def cost(x_scaled):
    global evaluations
    evaluations += 1
    arm, pend = np.clip(x_scaled, lower, upper) / 1e3
    r = simulate_fmu(unzipdir, model_description=md, stop_time=40.0, output_interval=0.01, input=signals,
                     start_values={"armFriction": arm, "pendulumFriction": pend},
                     output=["armJoint.phi", "pendulumJoint.phi"], relative_tolerance=1e-6)
    return float(np.sum((r["armJoint.phi"] - data["phi"]) ** 2) + np.sum((r["pendulumJoint.phi"] - data["theta"]) ** 2))


res = minimize(cost, np.array([12.0, 2.0]), method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-2})
wall = time.perf_counter() - start
x = np.clip(res.x, lower, upper) / 1e3
print(json.dumps({"seconds": wall, "evaluations": evaluations, "x_opt": {"armFriction": x[0], "pendulumFriction": x[1]}, "f_opt": res.fun}))
