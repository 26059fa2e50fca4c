#!/usr/bin/env bash
# Regenerates examples/exhaust/exhaust_data.csv (fixed seed; see generate_data.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
"$py" examples/exhaust/generate_data.py "$PWD/target/release/fmucal"
