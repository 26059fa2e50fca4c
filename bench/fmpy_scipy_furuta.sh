#!/usr/bin/env bash
# fmucal (2 workers) against FMPy + scipy.optimize.minimize on the same Furuta calibration:
# wall-time ratio and both evaluation counts.
set -euo pipefail
cd "$(dirname "$0")/.."
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
fmu="$(./target/release/fmucal examples | awk '$1=="furuta"{print $2}')"
out="$(mktemp -d)"
t0=$(date +%s.%N)
./target/release/fmucal calibrate examples/furuta/job.toml --workers 2 --out "$out" > /dev/null 2>&1
t1=$(date +%s.%N)
"$py" bench/fmpy_scipy_furuta.py "$fmu" | tail -1 > "$out/scipy.json"  # FMPy prints warnings on stdout
"$py" - "$out" "$(echo "$t1 - $t0" | bc -l)" <<'PY'
import json, os, sys
d, fmucal_wall = sys.argv[1], float(sys.argv[2])
ours = json.load(open(os.path.join(d, "result.json")))
theirs = json.load(open(os.path.join(d, "scipy.json")))
print("| | wall time [s] | evaluations | armFriction | pendulumFriction |")
print("|---|---|---|---|---|")
print(f"| fmucal calibrate, 2 workers (whole command) | {fmucal_wall:.2f} | {ours['evaluations']} | {ours['x_opt']['armFriction']:.6g} | {ours['x_opt']['pendulumFriction']:.6g} |")
print(f"| FMPy + scipy.optimize.minimize (Nelder-Mead) | {theirs['seconds']:.2f} | {theirs['evaluations']} | {theirs['x_opt']['armFriction']:.6g} | {theirs['x_opt']['pendulumFriction']:.6g} |")
print(f"\nfmucal / script wall time: {fmucal_wall / theirs['seconds']:.4f} (target <= 0.05)")
PY
