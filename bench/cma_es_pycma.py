"""pycma side of bench/cma_es.sh: the same cases as bench/cma_es.rs (10-D Rosenbrock in
[-2, 2]^10 from x0 = 0, 10-D Rastrigin in [-5, 5]^10 from x0 = (3, ..., 3), sigma0 = 0.3 of the
range, budgets 2 000 / 10 000 / 50 000 evaluations, seeds 1 to 11) with pycma's IPOP:
cma.fmin2(f, x0, sigma0, {'bounds': [lo, hi], 'maxfevals': budget, 'seed': seed},
restarts=9, incpopsize=2), its default population 4 + 3 ln n = 10 and default termination
criteria (bounds by its default BoundTransform).

The initial mean is x0 in the first run. Restarts start from a uniform random point in the box,
as fmucal's do (x0 is passed as a callable, which pycma calls at each restart); with
`--fixed-restarts` pycma's own default is kept instead (every restart from x0 again).

pycma checks maxfevals after a whole generation, so it may evaluate a little past the budget:
the result is the best of the first `budget` evaluations, counted by a wrapper.

Usage: python bench/cma_es_pycma.py [--fixed-restarts] > pycma.json"""
import json
import sys
import time
import warnings

import numpy as np

warnings.filterwarnings("ignore")
import cma  # noqa: E402

N = 10
BUDGETS = [2_000, 10_000, 50_000]
SEEDS = range(1, 12)


def rosenbrock(x):
    x = np.asarray(x)
    return float(np.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (1.0 - x[:-1]) ** 2))


def rastrigin(x):
    x = np.asarray(x)
    return float(10.0 * len(x) + np.sum(x * x - 10.0 * np.cos(2.0 * np.pi * x)))


CASES = [("rosenbrock", rosenbrock, -2.0, 2.0, 0.0), ("rastrigin", rastrigin, -5.0, 5.0, 3.0)]


def run(f, lo, hi, x0, budget, seed, random_restarts):
    state = {"n": 0, "best": np.inf}

    def counted(x):
        v = f(x)
        state["n"] += 1
        if state["n"] <= budget and v < state["best"]:
            state["best"] = v
        return v

    starts = np.random.default_rng(1000 + seed)
    calls = {"n": 0}

    def start():
        calls["n"] += 1
        if calls["n"] == 1:
            return np.full(N, x0)
        return starts.uniform(lo, hi, N)

    options = {"bounds": [lo, hi], "maxfevals": budget, "seed": seed, "verbose": -9}
    cma.fmin2(counted, start if random_restarts else np.full(N, x0), 0.3 * (hi - lo), options,
              restarts=9, incpopsize=2)
    return state["best"], min(state["n"], budget)


def main():
    random_restarts = "--fixed-restarts" not in sys.argv
    rows = []
    for name, f, lo, hi, x0 in CASES:
        for budget in BUDGETS:
            for seed in SEEDS:
                t = time.time()
                best, evals = run(f, lo, hi, x0, budget, seed, random_restarts)
                row = {"function": name, "budget": budget, "seed": seed, "best": best, "evaluations": evals,
                       "seconds": time.time() - t}
                print(json.dumps(row), file=sys.stderr)
                rows.append(row)
    json.dump(rows, sys.stdout)


if __name__ == "__main__":
    main()
