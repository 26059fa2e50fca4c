#!/usr/bin/env bash
# Regenerates examples/friction/data.csv: 20 s of the spring–mass with 0.05 m/s² of Coulomb
# friction compiled into its C code (SpringMassExportedHiddenCoulomb.fmu), released from
# x = 0.5 m, sampled every 20 ms, with Gaussian noise of 1 % of the position's range (fixed seed).
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q
bench="$(find target/release/build -name SpringMassExportedHiddenCoulomb.fmu -path '*fmucal-models*' | head -n 1)"
clean="$(mktemp)"
trap 'rm -f "$clean"' EXIT
target/release/fmucal simulate "$bench" --stop-time 20 --output-interval 0.02 --tolerance 1e-10 \
  --output mass.x -o "$clean" >/dev/null
python3 examples/friction/add_noise.py "$clean" examples/friction/data.csv
