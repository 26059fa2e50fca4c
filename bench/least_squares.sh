#!/usr/bin/env bash
# Least-squares benchmark: fmucal's LeastSquares against DFO-LS 1.6.5 (and, for reference,
# fmucal's Nelder–Mead) on the Moré–Garbow–Hillstrom least-squares problems and four
# two-parameter calibrations: evaluations and rounds to f <= f* + 1e-5 (f(x0) - f*).
# Prints a Markdown table.
# Usage: bash bench/least_squares.sh   (creates target/pyenv with DFO-LS on first use)
set -euo pipefail
cd "$(dirname "$0")/.."
py="$(bash tests/fmpy/ensure_venv.sh)"
out="$(mktemp -d)"
cargo bench --locked --bench least_squares -- --json "$out/fmucal.json" 2>/dev/null
"$py" bench/least_squares_dfols.py "$out/fmucal.json" > "$out/dfols.json"
"$py" - "$out" <<'PY'
import sys
from bench.rows import ours_and_theirs
ours, theirs = ours_and_theirs(sys.argv[1], "dfols.json")
fmt = lambda v: "-" if v is None else str(v)
pct = lambda a, b: "-" if a is None or b is None else f"{100 * a / b:.0f} %"
print(f"Threshold: f <= f* + tau (f(x0) - f*), tau = {ours[0]['tau']:g}; '-' = not reached "
      "(within 5000 evaluations for fmucal and DFO-LS, 20000 for Nelder-Mead).\n")
print("| problem | n | m | DFO-LS evals | fmucal evals | fmucal rounds | winner | NM evals / rounds (parallel) "
      "| fmucal / NM evals | fmucal / NM rounds |")
print("|---|---|---|---|---|---|---|---|---|---|")
wins = both = 0
for r in ours:
    dfo, e, rounds = theirs[r["problem"]]["dfols_evals"], r["ls_evals"], r["ls_rounds"]
    if e is None and dfo is None:
        winner = "neither"
    elif dfo is None or (e is not None and e < dfo):
        winner = "fmucal"
    elif e is not None and e == dfo:
        winner = "tie"
    else:
        winner = "DFO-LS"
    wins += winner in ("fmucal", "tie")
    name = r["problem"] + (" (box)" if r["calibration"] else "")
    ne, nr = r["nm_par_evals"], r["nm_par_rounds"]
    print(f"| {name} | {r['n']} | {r['m']} | {fmt(dfo)} | {fmt(e)} | {fmt(rounds)} | {winner} | "
          f"{fmt(ne)} / {fmt(nr)} | {pct(e, ne)} | {pct(rounds, nr)} |")
print(f"\nfmucal needs no more evaluations than DFO-LS on {wins} of {len(ours)} problems.")
cal = [r for r in ours if r["calibration"]]
if cal and all(r["ls_evals"] and r["nm_par_evals"] for r in cal):
    ev = [r["ls_evals"] / r["nm_par_evals"] for r in cal]
    ro = [r["ls_rounds"] / r["nm_par_rounds"] for r in cal]
    print(f"Two-parameter calibrations: fmucal needs {100 * min(ev):.0f}-{100 * max(ev):.0f} % of parallel "
          f"Nelder-Mead's simulations and {100 * min(ro):.0f}-{100 * max(ro):.0f} % of its rounds.")
print("\nCalibrations run as a job would, each solver with its default settings until it stops "
      "(gap = (f - f*) / (f(x0) - f*) at the end):\n")
print("| calibration | fmucal sims / rounds | gap | NM sims / rounds | gap | sims | rounds |")
print("|---|---|---|---|---|---|---|")
for r in cal:
    dr, span = r["default_runs"], r["f0"] - r["f_star"]
    print(f"| {r['problem']} | {dr['ls_evals']} / {dr['ls_rounds']} | {(dr['ls_best'] - r['f_star']) / span:.0e} | "
          f"{dr['nm_evals']} / {dr['nm_rounds']} | {(dr['nm_best'] - r['f_star']) / span:.0e} | "
          f"{pct(dr['ls_evals'], dr['nm_evals'])} | {pct(dr['ls_rounds'], dr['nm_rounds'])} |")
PY
