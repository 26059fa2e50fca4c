"""What a user would otherwise write for a cheap model in a large archive: calibrate the
stiffness k and damping d of the spring-mass fixture packaged with 13 MB of documentation
(SpringMassExportedDocumented.fmu) from 10 s of position data (1,000 samples) with FMPy
simulating the same FMU and scipy.optimize.minimize(method="Nelder-Mead"): the same start,
the bounds enforced by clipping, each parameter scaled by its range as fmucal scales it, the
tolerances of the fmucal job (xatol 1e-6 in scaled units, fatol 1e-12), rtol 1e-6. The FMU is
extracted and its description read once, as FMPy recommends for repeated simulations; both
are timed, as the user's script pays for them.
Prints JSON: wall time, evaluations, x_opt.

Usage: python bench/fmpy_scipy_spring_mass.py FMU DATA.csv   (bash bench/fmpy_scipy_local.sh)
"""
import json
import shutil
import sys
import time

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from scipy.optimize import minimize

fmu, data_csv = sys.argv[1], sys.argv[2]
data = np.genfromtxt(data_csv, delimiter=",", names=True)
lower, upper = np.array([0.5, 0.0]), np.array([10.0, 2.0])
start_x = np.array([3.5, 0.4])
evaluations = 0

start = time.perf_counter()
md = read_model_description(fmu)
unzipdir = extract(fmu)


def unscale(z):
    return lower + np.clip(z, 0.0, 1.0) * (upper - lower)


def cost(z):
    global evaluations
    evaluations += 1
    k, d = unscale(z)
    r = simulate_fmu(unzipdir, model_description=md, stop_time=10.0, output_interval=0.01,
                     start_values={"k": k, "d": d}, output=["mass.x"], relative_tolerance=1e-6)
    return float(np.sum((r["mass.x"] - data["x"]) ** 2))


res = minimize(cost, (start_x - lower) / (upper - lower), method="Nelder-Mead",
               options={"xatol": 1e-6, "fatol": 1e-12})
wall = time.perf_counter() - start
shutil.rmtree(unzipdir, ignore_errors=True)
x = unscale(res.x)
print(json.dumps({"seconds": wall, "evaluations": evaluations, "x_opt": {"k": x[0], "d": x[1]}, "f_opt": res.fun}))
