#!/usr/bin/env bash
# Regenerates examples/furuta/{furuta_data.csv,FurutaData.mat} (fixed seed; see generate_data.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
"$py" examples/furuta/generate_data.py "$PWD/target/release/fmucal"
