#!/usr/bin/env bash
# Regenerates the algorithm comparison table of docs/src/benchmarks/calibration.md (see compare_algorithms.py).
set -euo pipefail
cd "$(dirname "$0")/.."
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
"$py" bench/compare_algorithms.py "$PWD/target/release/fmucal"
