"""SciPy side of bench/optim.sh: the same Moré–Garbow–Hillstrom problems, starts and
thresholds as bench/optim.rs. Nelder–Mead: evaluations to reach f <= f* + 1e-6 (1 + |f*|)
(SciPy's default simplex, which fmucal's matches). Differential evolution: rand1bin, F 0.8,
CR 0.9, population 15 n, random init, deferred updating (one batch per generation, as
fmucal evaluates it), no polishing, the same number of generations, median
best over 5 seeds. Reads the problem list (name, n, f_star) from the fmucal JSON."""
import json
import sys

import numpy as np
from scipy.optimize import differential_evolution, minimize

GENERATIONS = 100


def rosenbrock(x): return 100 * (x[1] - x[0] ** 2) ** 2 + (1 - x[0]) ** 2
def freudenstein_roth(x):
    f1 = -13 + x[0] + ((5 - x[1]) * x[1] - 2) * x[1]
    f2 = -29 + x[0] + ((x[1] + 1) * x[1] - 14) * x[1]
    return f1 ** 2 + f2 ** 2
def powell_badly_scaled(x): return (1e4 * x[0] * x[1] - 1) ** 2 + (np.exp(-x[0]) + np.exp(-x[1]) - 1.0001) ** 2
def brown_badly_scaled(x): return (x[0] - 1e6) ** 2 + (x[1] - 2e-6) ** 2 + (x[0] * x[1] - 2) ** 2
def beale(x): return sum((y - x[0] * (1 - x[1] ** (i + 1))) ** 2 for i, y in enumerate([1.5, 2.25, 2.625]))
def helical_valley(x):
    theta = np.arctan2(x[1], x[0]) / (2 * np.pi)
    return (10 * (x[2] - 10 * theta)) ** 2 + (10 * (np.hypot(x[0], x[1]) - 1)) ** 2 + x[2] ** 2
def powell_singular(x):
    return (x[0] + 10 * x[1]) ** 2 + 5 * (x[2] - x[3]) ** 2 + (x[1] - 2 * x[2]) ** 4 + 10 * (x[0] - x[3]) ** 4
def wood(x):
    return (100 * (x[0] ** 2 - x[1]) ** 2 + (x[0] - 1) ** 2 + 90 * (x[2] ** 2 - x[3]) ** 2 + (1 - x[2]) ** 2
            + 10.1 * ((x[1] - 1) ** 2 + (x[3] - 1) ** 2) + 19.8 * (x[1] - 1) * (x[3] - 1))

PROBLEMS = {
    "Rosenbrock": (rosenbrock, [-1.2, 1.0], [(-5, 5)] * 2),
    "Freudenstein-Roth": (freudenstein_roth, [0.5, -2.0], [(-20, 20)] * 2),
    "Powell badly scaled": (powell_badly_scaled, [0.0, 1.0], [(-1, 1), (0, 10)]),
    "Brown badly scaled": (brown_badly_scaled, [1.0, 1.0], [(0, 2e6), (0, 1)]),
    "Beale": (beale, [1.0, 1.0], [(-4.5, 4.5)] * 2),
    "Helical valley": (helical_valley, [-1.0, 0.0, 0.0], [(-10, 10)] * 3),
    "Powell singular": (powell_singular, [3.0, -1.0, 0.0, 1.0], [(-4, 5)] * 4),
    "Wood": (wood, [-3.0, -1.0, -3.0, -1.0], [(-10, 10)] * 4),
}


def nm_evals_to_target(f, x0, target):
    state = {"n": 0, "best": np.inf, "hit": None}
    def counted(x):
        v = f(x)
        state["n"] += 1
        state["best"] = min(state["best"], v)
        if state["hit"] is None and state["best"] <= target:
            state["hit"] = state["n"]
        return v
    minimize(counted, np.array(x0), method="Nelder-Mead",
             options={"xatol": 1e-12, "fatol": 1e-14, "maxfev": 20000, "maxiter": 20000})
    return state["hit"], state["best"]


def main():
    ours = json.load(open(sys.argv[1]))
    out = []
    for row in ours:
        f, x0, bounds = PROBLEMS[row["problem"]]
        target = row["f_star"] + 1e-6 * (1 + abs(row["f_star"]))
        hit, best = nm_evals_to_target(f, x0, target)
        n = len(x0)
        de = []
        for seed in range(5):
            r = differential_evolution(f, bounds, strategy="rand1bin", mutation=0.8, recombination=0.9,
                                       popsize=15, maxiter=GENERATIONS, tol=0, atol=0, polish=False,
                                       init="random", updating="deferred", seed=seed)
            de.append((r.fun, r.nfev))
        de.sort()
        out.append({"problem": row["problem"], "scipy_nm_evals": hit, "scipy_nm_best": best,
                    "scipy_de_median_best": de[2][0], "scipy_de_evals": de[2][1]})
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
