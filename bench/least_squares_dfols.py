"""DFO-LS side of bench/least_squares.sh: DFO-LS 1.6.5 (Cartis & Roberts) on the same
least-squares problems, starts, bounds and threshold as bench/least_squares.rs: evaluations
until f <= f* + tau (f(x0) - f*), counted by a wrapper around the residual function.

DFO-LS runs with its default settings and maxfun 5000: on the unbounded Moré–Garbow–Hillstrom
problems rhobeg = 0.1 max(|x0|_inf, 1) and rhoend 1e-8; on the bounded calibrations it is
given the box and scaling_within_bounds=True (its documented option for bounds of different
scales, which makes it work on [0, 1]^n as fmucal does), so rhobeg is 0.1 of each range.
DFO-LS evaluates one point at a time, so its rounds equal its evaluations. Reads the problem
list (name, x0, bounds, f0, f_star, tau) from the fmucal JSON and checks that f(x0) agrees, so
that both sides define the problems alike."""
import json
import sys
import warnings

import dfols
import numpy as np

MAXFUN = 5000


def rosenbrock(x): return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])
def freudenstein_roth(x):
    return np.array([-13 + x[0] + ((5 - x[1]) * x[1] - 2) * x[1], -29 + x[0] + ((x[1] + 1) * x[1] - 14) * x[1]])
def powell_badly_scaled(x): return np.array([1e4 * x[0] * x[1] - 1, np.exp(-x[0]) + np.exp(-x[1]) - 1.0001])
def brown_badly_scaled(x): return np.array([x[0] - 1e6, x[1] - 2e-6, x[0] * x[1] - 2])
def beale(x): return np.array([y - x[0] * (1 - x[1] ** (i + 1)) for i, y in enumerate([1.5, 2.25, 2.625])])
def jennrich_sampson(x):
    i = np.arange(1, 11)
    return 2 + 2 * i - (np.exp(i * x[0]) + np.exp(i * x[1]))
def helical_valley(x):
    theta = np.arctan2(x[1], x[0]) / (2 * np.pi)
    return np.array([10 * (x[2] - 10 * theta), 10 * (np.hypot(x[0], x[1]) - 1), x[2]])
BARD_Y = [0.14, 0.18, 0.22, 0.25, 0.29, 0.32, 0.35, 0.39, 0.37, 0.58, 0.73, 0.96, 1.34, 2.10, 4.39]
def bard(x):
    u = np.arange(1, 16)
    v = 16 - u
    return np.array(BARD_Y) - (x[0] + u / (v * x[1] + np.minimum(u, v) * x[2]))
GAUSSIAN_Y = [0.0009, 0.0044, 0.0175, 0.0540, 0.1295, 0.2420, 0.3521, 0.3989, 0.3521, 0.2420, 0.1295, 0.0540,
              0.0175, 0.0044, 0.0009]
def gaussian(x):
    t = (8 - np.arange(1, 16)) / 2
    return x[0] * np.exp(-x[1] * (t - x[2]) ** 2 / 2) - np.array(GAUSSIAN_Y)
MEYER_Y = [34780, 28610, 23650, 19630, 16370, 13720, 11540, 9744, 8261, 7030, 6005, 5147, 4427, 3820, 3307, 2872]
def meyer(x):
    t = 45 + 5 * np.arange(1, 17)
    return x[0] * np.exp(x[1] / (t + x[2])) - np.array(MEYER_Y)
def box_3d(x):
    t = 0.1 * np.arange(1, 11)
    return np.exp(-t * x[0]) - np.exp(-t * x[1]) - x[2] * (np.exp(-t) - np.exp(-10 * t))
def powell_singular(x):
    return np.array([x[0] + 10 * x[1], np.sqrt(5) * (x[2] - x[3]), (x[1] - 2 * x[2]) ** 2,
                     np.sqrt(10) * (x[0] - x[3]) ** 2])
def wood(x):
    return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0], np.sqrt(90) * (x[3] - x[2] ** 2), 1 - x[2],
                     np.sqrt(10) * (x[1] + x[3] - 2), (x[1] - x[3]) / np.sqrt(10)])
KOWALIK_Y = [0.1957, 0.1947, 0.1735, 0.1600, 0.0844, 0.0627, 0.0456, 0.0342, 0.0323, 0.0235, 0.0246]
KOWALIK_U = [4, 2, 1, 0.5, 0.25, 0.167, 0.125, 0.1, 0.0833, 0.0714, 0.0625]
def kowalik_osborne(x):
    u = np.array(KOWALIK_U)
    return np.array(KOWALIK_Y) - x[0] * (u ** 2 + u * x[1]) / (u ** 2 + u * x[2] + x[3])
def brown_dennis(x):
    t = np.arange(1, 21) / 5
    return (x[0] + t * x[1] - np.exp(t)) ** 2 + (x[2] + x[3] * np.sin(t) - np.cos(t)) ** 2
OSBORNE1_Y = [0.844, 0.908, 0.932, 0.936, 0.925, 0.908, 0.881, 0.850, 0.818, 0.784, 0.751, 0.718, 0.685, 0.658,
              0.628, 0.603, 0.580, 0.558, 0.538, 0.522, 0.506, 0.490, 0.478, 0.467, 0.457, 0.448, 0.438, 0.431,
              0.424, 0.420, 0.414, 0.411, 0.406]
def osborne_1(x):
    t = 10 * np.arange(0, 33)
    return np.array(OSBORNE1_Y) - (x[0] + x[1] * np.exp(-t * x[3]) + x[2] * np.exp(-t * x[4]))
def biggs_exp6(x):
    t = 0.1 * np.arange(1, 14)
    y = np.exp(-t) - 5 * np.exp(-10 * t) + 3 * np.exp(-4 * t)
    return x[2] * np.exp(-t * x[0]) - x[3] * np.exp(-t * x[1]) + x[5] * np.exp(-t * x[4]) - y
def penalty_1(x):
    return np.concatenate([np.sqrt(1e-5) * (np.asarray(x) - 1), [np.dot(x, x) - 0.25]])


def noise(i):
    """Deterministic stand-in for measurement noise in [-1, 1): fractional parts of i / golden ratio."""
    return ((np.asarray(i, dtype=float) * 0.6180339887498949) % 1.0 - 0.5) * 2.0
def spring_step(k, d, t):
    w = np.sqrt(k)
    z = d / (2 * w)
    wd = w * np.sqrt(1 - z * z)
    return (1 - np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))) / k
SPRING_I = np.arange(1, 101)
def spring_damper(x):
    t = 0.1 * SPRING_I
    return spring_step(x[0], x[1], t) - (spring_step(4.0, 0.8, t) + 0.002 * noise(SPRING_I))
def logistic(k, r, t): return k / (1 + (k / 0.5 - 1) * np.exp(-r * t))
LOGISTIC_I = np.arange(1, 41)
def logistic_growth(x):
    t = 0.5 * LOGISTIC_I
    return logistic(x[0], x[1], t) - logistic(8.0, 0.6, t) * (1 + 0.01 * noise(LOGISTIC_I + 100))
MM_SUBSTRATE = np.array([0.02, 0.04, 0.06, 0.08, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0,
                         5.0, 7.5, 10.0, 15.0])
def michaelis_menten(x):
    s = MM_SUBSTRATE
    return x[0] * s / (x[1] + s) - (2.5 * s / (0.7 + s) + 0.02 * noise(np.arange(1, 21) + 200))
def vibration(w, z, t): return np.exp(-z * w * t) * np.cos(w * np.sqrt(1 - z * z) * t)
VIBRATION_I = np.arange(1, 121)
def free_vibration(x):
    t = 0.05 * VIBRATION_I
    return vibration(x[0], x[1], t) - (vibration(3.0, 0.15, t) + 0.01 * noise(VIBRATION_I + 300))

PROBLEMS = {
    "Rosenbrock": (rosenbrock, [-1.2, 1.0]),
    "Freudenstein-Roth": (freudenstein_roth, [0.5, -2.0]),
    "Powell badly scaled": (powell_badly_scaled, [0.0, 1.0]),
    "Brown badly scaled": (brown_badly_scaled, [1.0, 1.0]),
    "Beale": (beale, [1.0, 1.0]),
    "Jennrich-Sampson": (jennrich_sampson, [0.3, 0.4]),
    "Helical valley": (helical_valley, [-1.0, 0.0, 0.0]),
    "Bard": (bard, [1.0, 1.0, 1.0]),
    "Gaussian": (gaussian, [0.4, 1.0, 0.0]),
    "Meyer": (meyer, [0.02, 4000.0, 250.0]),
    "Box 3-D": (box_3d, [0.0, 10.0, 20.0]),
    "Powell singular": (powell_singular, [3.0, -1.0, 0.0, 1.0]),
    "Wood": (wood, [-3.0, -1.0, -3.0, -1.0]),
    "Kowalik-Osborne": (kowalik_osborne, [0.25, 0.39, 0.415, 0.39]),
    "Brown-Dennis": (brown_dennis, [25.0, 5.0, -5.0, -1.0]),
    "Osborne 1": (osborne_1, [0.5, 1.5, -1.0, 0.01, 0.02]),
    "Biggs EXP6": (biggs_exp6, [1.0, 2.0, 1.0, 1.0, 1.0, 1.0]),
    "Penalty I": (penalty_1, [1.0, 2.0, 3.0, 4.0]),
    "Spring-damper step": (spring_damper, [5.5, 1.5]),
    "Logistic growth": (logistic_growth, [5.0, 1.0]),
    "Michaelis-Menten": (michaelis_menten, [1.0, 2.0]),
    "Free vibration": (free_vibration, [2.6, 0.3]),
}


def evals_to_target(residuals, x0, bounds, target):
    state = {"n": 0, "best": np.inf, "hit": None}

    def counted(x):
        r = residuals(x)
        state["n"] += 1
        state["best"] = min(state["best"], float(np.dot(r, r)))
        if state["hit"] is None and state["best"] <= target:
            state["hit"] = state["n"]
        return r

    options = {}
    if bounds is not None:
        options = {"bounds": (np.array(bounds[0], dtype=float), np.array(bounds[1], dtype=float)),
                   "scaling_within_bounds": True}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dfols.solve(counted, np.array(x0, dtype=float), maxfun=MAXFUN, **options)
    return state["hit"], state["n"], state["best"]


def main():
    ours = json.load(open(sys.argv[1]))
    out = []
    for row in ours:
        residuals, x0 = PROBLEMS[row["problem"]]
        if list(x0) != list(row["x0"]):
            sys.exit(f"{row['problem']}: x0 is {x0} here and {row['x0']} in fmucal's definition")
        r0 = residuals(np.array(x0, dtype=float))
        f0 = float(np.dot(r0, r0))
        if abs(f0 - row["f0"]) > 1e-10 * abs(row["f0"]):
            sys.exit(f"{row['problem']}: f(x0) is {f0} here and {row['f0']} in fmucal's definition")
        target = row["f_star"] + row["tau"] * (f0 - row["f_star"])
        hit, total, best = evals_to_target(residuals, x0, row["bounds"], target)
        out.append({"problem": row["problem"], "dfols_evals": hit, "dfols_total_evals": total, "dfols_best": best})
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
