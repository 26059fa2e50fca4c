#!/usr/bin/env bash
# CMA-ES benchmark: fmucal's CMA-ES (IPOP) against pycma's fmin2 (IPOP, restarts=9,
# incpopsize=2) on 10-D Rosenbrock in [-2, 2]^10 (x0 = 0) and 10-D Rastrigin in [-5, 5]^10
# (x0 = 3), sigma0 = 0.3 of the range, budgets 2 000 / 10 000 / 50 000 evaluations, 11 seeds.
# pycma runs twice: restarting from uniform random points like fmucal (the comparison of the
# verdicts), and with its default of restarting from x0. Prints a Markdown table and one verdict
# per (function, budget). Usage: bash bench/cma_es.sh   (creates target/pyenv on first use;
# about 15 minutes, nearly all of it pycma)
set -euo pipefail
cd "$(dirname "$0")/.."
py="$(bash tests/fmpy/ensure_venv.sh)"
out="$(mktemp -d)"
cargo bench --locked --bench cma_es -- --json "$out/fmucal.json" 2>/dev/null
"$py" bench/cma_es_pycma.py > "$out/pycma.json" 2>/dev/null
"$py" bench/cma_es_pycma.py --fixed-restarts > "$out/pycma_x0.json" 2>/dev/null
"$py" - "$out" <<'PY'
import json, os, statistics, sys
from collections import defaultdict
d = sys.argv[1]
def load(name):
    g = defaultdict(list)
    for r in json.load(open(os.path.join(d, name))):
        g[(r["function"], r["budget"])].append(r)
    return g
ours, theirs, theirs_x0 = load("fmucal.json"), load("pycma.json"), load("pycma_x0.json")
box = {"rosenbrock": "[-2, 2]^10", "rastrigin": "[-5, 5]^10"}
SOLVED = 1e-8
def stats(rows):
    v = [r["best"] for r in rows]
    return statistics.median(v), min(v), sum(x <= SOLVED for x in v)
def verdict(a, b):
    if a <= SOLVED and b <= SOLVED:
        return f"both medians <= {SOLVED:g}: tie"
    if a <= SOLVED:
        return f"fmucal better (median <= {SOLVED:g}, pycma {b:.3g})"
    if b <= SOLVED:
        return f"fmucal worse (pycma median <= {SOLVED:g}, fmucal {a:.3g})"
    r = a / b
    if r < 0.5:
        return f"fmucal better: median {r:.2f} x pycma's"
    if r <= 2:
        return f"fmucal within a factor 2 of pycma: median {r:.2f} x pycma's"
    return f"fmucal worse: median {r:.2f} x pycma's"
print(f"| function (n = 10) | box | budget | seeds | fmucal median | fmucal best | fmucal runs <= {SOLVED:g} "
      f"| pycma median | pycma best | pycma runs <= {SOLVED:g} | pycma restarting from x0: median | best |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
lines = []
for key, rows in ours.items():
    (fm, fb, fs), (pm, pb, ps), (xm, xb, _) = stats(rows), stats(theirs[key]), stats(theirs_x0[key])
    f, budget = key
    print(f"| {f} | {box[f]} | {budget} | {len(rows)} | {fm:.3g} | {fb:.3g} | {fs} | {pm:.3g} | {pb:.3g} | {ps} "
          f"| {xm:.3g} | {xb:.3g} |")
    lines.append(f"- {f}, {budget} evaluations: {verdict(fm, pm)}")
print()
print("\n".join(lines))
secs = lambda g: sum(r["seconds"] for rows in g.values() for r in rows)
print(f"\nwall time, all runs: fmucal {secs(ours):.1f} s, pycma {secs(theirs):.1f} s (+ {secs(theirs_x0):.1f} s restarting from x0)")
PY
