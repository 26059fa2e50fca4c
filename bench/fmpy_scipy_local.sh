#!/usr/bin/env bash
# A local `fmucal calibrate` on a cheap model in a large archive, against the FMPy + SciPy
# script a user would write (bench/fmpy_scipy_spring_mass.py): the spring-mass fixture packaged
# with 13 MB of documentation as commercial tools package FMUs (SpringMassExportedDocumented.fmu,
# 2 states), k and d fitted to 10 s of position data (1,000 samples, 1 % noise, seeded) with
# Nelder-Mead, 2 workers, every default on (tolerance guard, identifiability, plots). The two
# run interleaved ROUNDS times (the order flips every round, so drift in the machine's load
# hits both alike); fmucal is timed as the whole command, the script from reading the FMU to
# its optimum (its Python start-up and imports are not counted). Prints each round, the
# medians and the median of the per-round ratios.
# Usage: bash bench/fmpy_scipy_local.sh [ROUNDS]   (ROUNDS defaults to 7)
set -euo pipefail
cd "$(dirname "$0")/.."
rounds="${1:-7}"
case "$rounds" in ''|*[!0-9]*) echo "ROUNDS must be a whole number, got $rounds" >&2; exit 2 ;; esac
if [ "$rounds" -lt 1 ] || [ "$rounds" -gt 100 ]; then echo "ROUNDS must be 1 to 100, got $rounds" >&2; exit 2; fi
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
F="$PWD/target/release/fmucal"
# The fixture as this build made it (the newest, if cargo kept older build folders).
fmu="$(ls -t target/release/build/fmucal-models-*/out/fmus/SpringMassExportedDocumented.fmu 2>/dev/null | head -1)"
[ -n "$fmu" ] || { echo "no SpringMassExportedDocumented.fmu under target/release/build" >&2; exit 1; }
fmu="$PWD/$fmu"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# The data: the model at k = 4, d = 0.3 (its defaults), with 1 % of the range as noise.
"$F" simulate "$fmu" --stop-time 10 --output-interval 0.01 --tolerance 1e-10 --output mass.x \
  -o "$work/clean.csv" >/dev/null 2>&1
"$py" - "$work/clean.csv" "$work/data.csv" <<'PY'
import sys
import numpy as np
t, x = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1, unpack=True)
x = x + np.random.default_rng(7).normal(0, 0.01 * np.ptp(x), len(x))
np.savetxt(sys.argv[2], np.column_stack([t, x]), delimiter=",", header="time,x", comments="", fmt="%.17g")
PY
cat >"$work/job.toml" <<TOML
[model]
path = "$fmu"
[data]
path = "$work/data.csv"
[[outputs]]
variable = "mass.x"
column = "x"
$(cat tests/data/parameters/spring_mass.toml)
[simulation]
tolerance = 1e-6
[optimizer]
algorithm = "nelder-mead"
x_tol = 1e-6
f_tol = 1e-12
[workers]
count = 2
TOML

# What a user of fmucal has once run before: the archive sits unpacked in the FMU cache.
"$F" calibrate "$work/job.toml" --out "$work/warm" >/dev/null 2>&1
for i in $(seq 1 "$rounds"); do
  if [ $((i % 2)) = 1 ]; then order="fmucal script"; else order="script fmucal"; fi
  for which in $order; do
    if [ "$which" = fmucal ]; then
      t0=$(date +%s.%N)
      "$F" calibrate "$work/job.toml" --out "$work/out-$i" >/dev/null 2>&1
      t1=$(date +%s.%N)
      echo "$t1 - $t0" | bc -l >"$work/fmucal-$i.s"
    else
      "$py" bench/fmpy_scipy_spring_mass.py "$fmu" "$work/data.csv" | tail -1 >"$work/script-$i.json"
    fi
  done
done
"$py" - "$work" "$rounds" <<'PY'
import json, os, statistics, sys
d, rounds = sys.argv[1], int(sys.argv[2])
ours = [float(open(os.path.join(d, f"fmucal-{i}.s")).read()) for i in range(1, rounds + 1)]
theirs = [json.load(open(os.path.join(d, f"script-{i}.json"))) for i in range(1, rounds + 1)]
result = json.load(open(os.path.join(d, "out-1", "result.json")))
print("| round | fmucal calibrate [s] | FMPy + SciPy script [s] | ratio |")
print("|---|---|---|---|")
ratios = []
for i, (a, b) in enumerate(zip(ours, theirs), 1):
    ratios.append(a / b["seconds"])
    print(f"| {i} | {a:.3f} | {b['seconds']:.3f} | {ratios[-1]:.3f} |")
t = theirs[0]
print(f"\nevaluations: fmucal {result['evaluations']} (k = {result['x_opt']['k']:.6g}, d = {result['x_opt']['d']:.6g}); "
      f"script {t['evaluations']} (k = {t['x_opt']['k']:.6g}, d = {t['x_opt']['d']:.6g})")
print(f"median wall time: fmucal {statistics.median(ours):.3f} s, script {statistics.median(s['seconds'] for s in theirs):.3f} s")
print(f"median fmucal / script wall time: {statistics.median(ratios):.3f} (target <= 0.1)")
PY
