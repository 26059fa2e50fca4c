#!/usr/bin/env bash
# The paper's exhaust-pipe calibration: stage 1 (right volume), stage 2 (left volume, right
# fixed at stage 1's result), and all four parameters at once for comparison.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q
for stage in stage1_right:stage1 stage2_left:stage2 all_four:all4; do
  ./target/release/fmucal calibrate "examples/exhaust/${stage%%:*}.toml" --out "examples/exhaust/${stage##*:}"
done
