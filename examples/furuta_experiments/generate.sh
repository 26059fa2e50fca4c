#!/usr/bin/env bash
# Regenerates examples/furuta_experiments/{sine,steps,chirp}.csv (fixed seed; see generate_data.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
"$py" examples/furuta_experiments/generate_data.py "$PWD/target/release/fmucal"
