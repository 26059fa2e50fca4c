#!/usr/bin/env bash
# Nelder–Mead against least squares as the default solver: simulations to within 1 % of each
# case's best f, from the job's start and 3 seeded random starts, on the calibration examples,
# the diagnosis benchmarks' base jobs, the hybrid fixtures (stick-slip, bouncing ball, dead
# zone) and the Dymola-shaped fixtures; prints the table, the failures and whether the decision
# rule holds (see bench/solver_choice.rs). Usage: bash bench/solver_choice.sh [--case TEXT]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo bench --bench solver_choice -- "$@" 2>/dev/null
