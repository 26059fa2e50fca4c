#!/usr/bin/env bash
# Regenerates examples/diagnose/data.csv from the hidden-Coulomb Furuta bench (fixed seed; see
# generate_data.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
py="$(bash tests/fmpy/ensure_venv.sh)"
cargo build --release -q
bench="$(find target/release/build -name FurutaHiddenCoulomb.fmu -path '*fmucal-models*' | head -n 1)"
"$py" examples/diagnose/generate_data.py "$PWD/target/release/fmucal" "$PWD/$bench"
