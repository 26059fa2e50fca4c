#!/usr/bin/env bash
# The capacity benchmark (bench/capacity.rs): a `fmucal coordinator` process and 1,000
# simulated worker slots (250 workers of 4 slots, one connection each) in this process that
# speak the real worker protocol and answer each point after a set simulation time. Prints
# sustained results/s against the ideal, lease-to-result latency p50/p99, the coordinator's CPU
# per result and its RSS over the run, this process's CPU, the store's size, and after a
# SIGKILL the journal's bytes per point; then a Markdown table for docs/src/benchmarks/service.md.
# The argument is the number of results measured (default 1,000,000). Knobs:
# FMUCAL_CAPACITY_SIM_MS (50; 0 answers at once), FMUCAL_CAPACITY_SLOTS (1000),
# FMUCAL_CAPACITY_CONNECTIONS (250), FMUCAL_CAPACITY_JOBS (150), FMUCAL_CAPACITY_OPTIMIZER
# (de, cma-es, nm, ls), FMUCAL_CAPACITY_POPULATION (20), FMUCAL_CAPACITY_FEVALS (4000),
# FMUCAL_CAPACITY_PARAMETERS (2), FMUCAL_CAPACITY_WARMUP_S (5).
#   bash bench/capacity.sh
#   bash bench/capacity.sh 10000000
#   FMUCAL_CAPACITY_SIM_MS=0 bash bench/capacity.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo bench --locked --bench capacity -- "$@"
