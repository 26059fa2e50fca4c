#!/usr/bin/env bash
# The wall-time target of issue 10, step 4: with 4 workers a diagnosis must not take longer
# than the base calibration time × (1 + K/2), K the number of candidates fitted (`top`,
# default 8). Builds release and runs `fmucal diagnose --workers 4` on the Furuta example and
# on one exhaust-pipe case with a hidden radiation loss (written by the ignored test
# `speed_case` of tests/diagnosis_grid.rs); prints, per case, the base calibration time, the
# diagnosis time, their ratio, the allowed ratio, what was named, and the seconds and
# simulations of each phase (report.json's `phases`). Set DIAGNOSE_SPEED_DIR to keep the runs.
#   bash bench/diagnose_speed.sh
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
if [[ -n "${DIAGNOSE_SPEED_DIR:-}" ]]; then
  dir=$DIAGNOSE_SPEED_DIR
  mkdir -p "$dir"
else
  dir=$(mktemp -d)
  trap 'rm -rf "$dir"' EXIT
fi
cargo build --release --locked --bin fmucal >/dev/null 2>&1 || cargo build --release --locked --bin fmucal
DIAGNOSE_SPEED_DIR="$dir/exhaust" cargo test --release --locked --test diagnosis_grid -- --ignored speed_case >/dev/null 2>&1 \
  || DIAGNOSE_SPEED_DIR="$dir/exhaust" cargo test --release --locked --test diagnosis_grid -- --ignored speed_case
fmucal="$root/target/release/fmucal"

run() { # name, folder, job
  local name=$1 folder=$2 job=$3
  (cd "$folder" && "$fmucal" diagnose "$job" --workers 4 --out "$dir/$name-out" >/dev/null 2>"$dir/$name.err") \
    || { cat "$dir/$name.err"; exit 1; }
  python3 - "$name" "$dir/$name-out/report.json" <<'PY'
import json, sys
name, path = sys.argv[1], sys.argv[2]
r = json.load(open(path))
base, total = r["base_calibration_s"], r["elapsed_s"]
fitted = [c for c in r["rounds"][0]["candidates"] if c.get("fit")]
k = len(fitted)
allowed = 1 + 8 / 2
named = r["named"][0]["words"] if r["named"] else "no effect found"
print(f"{name}: base calibration {base:.2f} s, diagnosis {total:.2f} s, ratio {total / base:.1f} "
      f"(allowed 1 + K/2 = {allowed:.0f} for K = 8; {k} fitted) -> {'met' if total <= allowed * base else 'NOT met'}")
print(f"  named: {named}")
phases = r.get("phases", {})
if phases:
    print("  phases: " + ", ".join(f"{p} {v['seconds']:.2f} s/{v['simulations']}" for p, v in phases.items()))
print("  fits: " + ", ".join(f"{c['description'].split(' ')[0]} {c['fit']['evaluations']} ev {c['fit']['elapsed_s']:.2f} s" for c in fitted))
PY
}

run furuta "$root/examples/diagnose" job.toml
run exhaust "$dir/exhaust" job.toml
