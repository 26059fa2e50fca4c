#!/usr/bin/env bash
# Prints what a diagnosis found, without its wall times: `report.json` (keys elapsed_s,
# base_calibration_s and seconds removed, sorted) and the `job.toml` it writes, for comparing
# two builds bit for bit:
#   FMUCAL_BIN=old/fmucal bash bench/diagnosis_dump.sh > a
#   FMUCAL_BIN=new/fmucal bash bench/diagnosis_dump.sh > b && cmp a b
# Usage: bash bench/diagnosis_dump.sh [JOB ...] (default: examples/friction/job.toml and
# examples/diagnose/job.toml). FMUCAL_BIN defaults to target/release/fmucal.
set -euo pipefail
cd "$(dirname "$0")/.."
bin="${FMUCAL_BIN:-target/release/fmucal}"
[ -x "$bin" ] || { echo "diagnosis_dump: no fmucal binary at $bin (cargo build --release, or set FMUCAL_BIN)" >&2; exit 2; }
jobs=("$@")
[ ${#jobs[@]} -gt 0 ] || jobs=(examples/friction/job.toml examples/diagnose/job.toml)
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for job in "${jobs[@]}"; do
  echo "== $job"
  "$bin" diagnose "$job" --workers 2 --out "$out/d" > /dev/null 2> "$out/stderr" \
    || { cat "$out/stderr" >&2; exit 1; }
  python3 - "$out/d/report.json" <<'PY'
import json, sys
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k not in ("elapsed_s", "base_calibration_s", "seconds")}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
print(json.dumps(strip(json.load(open(sys.argv[1]))), indent=1, sort_keys=True))
PY
  cat "$out/d/job.toml"
  rm -rf "$out/d"
done
