#!/usr/bin/env bash
# Solver benchmark: simulations, batch rounds and wall time (4 evaluation threads)
# for Nelder–Mead, least squares and CMA-ES to come within 1 % of Nelder–Mead's optimum on the
# Furuta and exhaust examples. Prints a Markdown table (see bench/solvers.rs).
# Usage: bash bench/solvers.sh [--json FILE] [--problem NAME] [--history]
set -euo pipefail
cd "$(dirname "$0")/.."
cargo bench --bench solvers -- "$@" 2>/dev/null
