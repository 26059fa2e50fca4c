#!/usr/bin/env bash
# The wall-time target of discrepancy discovery: with 4 workers a diagnosis must not take longer
# than the base calibration time × (1 + K/2), K the number of candidates fitted (`top`,
# default 8), as the median of 5 runs. Builds release and runs `fmucal diagnose --workers 4`
# five times on each of: the Furuta example (examples/diagnose, ports), the friction example of
# a model with no injection input (examples/friction, state effects), and one exhaust-pipe case
# with a hidden radiation loss (written by the ignored test `speed_case` of
# tests/diagnosis_grid.rs). Prints, per case, the median run's base calibration time, diagnosis
# time and ratio, every run's ratio, the allowed ratio, what was named, the seconds and
# simulations of each phase (report.json's `phases`), and the simulations on the critical path
# (every phase but the fits, plus the longest fit), which do not depend on the machine's load.
# Set DIAGNOSE_SPEED_DIR to keep the runs.
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
fmucal="${CARGO_TARGET_DIR:-$root/target}/release/fmucal"

run() { # name, folder, job: five runs, the median ratio
  local name=$1 folder=$2 job=$3
  for k in 1 2 3 4 5; do
    (cd "$folder" && "$fmucal" diagnose "$job" --workers 4 --out "$dir/$name-out$k" >/dev/null 2>"$dir/$name.err") \
      || { cat "$dir/$name.err"; exit 1; }
  done
  python3 - "$name" "$dir"/"$name"-out{1,2,3,4,5}/report.json <<'PY'
import json, statistics, sys
name, paths = sys.argv[1], sys.argv[2:]
reports = [json.load(open(p)) for p in paths]
ratios = sorted(r["elapsed_s"] / r["base_calibration_s"] for r in reports)
r = sorted(reports, key=lambda r: r["elapsed_s"] / r["base_calibration_s"])[len(reports) // 2]
base, total = r["base_calibration_s"], r["elapsed_s"]
fitted = [c for c in r["rounds"][0]["candidates"] if c.get("fit")]
k = len(fitted)
allowed = 1 + 8 / 2
median = statistics.median(ratios)
named = r["named"][0]["words"] if r["named"] else r.get("conclusion", "no effect found")
print(f"{name}: median of {len(ratios)} runs: base calibration {base:.2f} s, diagnosis {total:.2f} s, ratio {median:.1f} "
      f"(runs {', '.join(f'{x:.1f}' for x in ratios)}; allowed 1 + K/2 = {allowed:.0f} for K = 8; {k} fitted) "
      f"-> {'met' if median <= allowed else 'NOT met'}")
print(f"  named: {named}")
phases = r.get("phases", {})
if phases:
    print("  phases: " + ", ".join(f"{p} {v['seconds']:.2f} s/{v['simulations']}" for p, v in phases.items()))
    # Simulations on the critical path: everything but the fits, plus the longest fit.
    longest = max((c["fit"]["evaluations"] for c in fitted), default=0)
    serial = sum(v["simulations"] for p, v in phases.items() if p != "fits") + longest
    print(f"  simulations: {sum(v['simulations'] for v in phases.values())} in all, {serial} on the critical path "
          f"(base calibration {phases.get('base', {}).get('simulations', 0)})")
print("  fits: " + ", ".join(f"{c['description'].split(' ')[0]} {c['fit']['evaluations']} ev {c['fit']['elapsed_s']:.2f} s" for c in fitted))
PY
}

run furuta "$root/examples/diagnose" job.toml
run exhaust "$dir/exhaust" job.toml
run friction "$root/examples/friction" job.toml
