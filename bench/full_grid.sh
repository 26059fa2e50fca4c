#!/usr/bin/env bash
# Runs the ignored test `full_grid` of tests/TEST.rs, one case at a time, and prints the lines
# of its output that match the extended regular expression FILTER (the table, the targets); if
# the test fails, the last 40 lines of its output instead.
# Usage: bash bench/full_grid.sh TEST FILTER   (bench/diagnose_grid.sh, bench/diagnose_exported.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
test="$1" filter="$2"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! cargo test --release --locked --test "$test" -- --ignored --nocapture --test-threads 1 full_grid >"$log" 2>&1; then
  tail -n 40 "$log"
  exit 1
fi
grep -E "$filter" "$log"
