#!/usr/bin/env bash
# Optimizer benchmark: fmucal's Nelder–Mead (sequential and parallel) and
# differential evolution against SciPy on the Moré–Garbow–Hillstrom problems. Prints a
# Markdown table. Usage: bash bench/optim.sh   (creates target/pyenv with SciPy on first use)
set -euo pipefail
cd "$(dirname "$0")/.."
py="$(bash tests/fmpy/ensure_venv.sh)"
out="$(mktemp -d)"
cargo bench --bench optim -- --json "$out/fmucal.json" 2>/dev/null
"$py" bench/optim_scipy.py "$out/fmucal.json" > "$out/scipy.json"
"$py" - "$out" <<'PY'
import sys
from bench.rows import ours_and_theirs
ours, theirs = ours_and_theirs(sys.argv[1], "scipy.json")
fmt = lambda v: "not reached" if v is None else str(v)
print("| problem | n | SciPy NM evals | fmucal sequential NM evals | fmucal parallel NM rounds | rounds / sequential evals | SciPy DE best | fmucal DE best | DE evals each |")
print("|---|---|---|---|---|---|---|---|---|")
wins = ratio_ok = 0
for r in ours:
    s = theirs[r["problem"]]
    seq, par, sp = r["nm_seq_evals"], r["nm_par_rounds"], s["scipy_nm_evals"]
    ratio = f"{par / seq:.2f}" if seq and par else "-"
    wins += bool(seq is not None and (sp is None or seq <= sp))
    ratio_ok += bool(seq and par and par / seq <= 0.6)
    print(f"| {r['problem']} | {r['n']} | {fmt(sp)} | {fmt(seq)} | {fmt(par)} | {ratio} | "
          f"{s['scipy_de_median_best']:.3g} | {r['de_median_best']:.3g} | {r['de_evals']} |")
print(f"\nsequential NM within SciPy's count on {wins} of {len(ours)} problems; "
      f"parallel rounds <= 0.6 x sequential evaluations on {ratio_ok} of {len(ours)}")
PY
