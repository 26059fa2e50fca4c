#!/usr/bin/env bash
# The load test (bench/load.rs): a `fmucal coordinator` process and 4 `fmucal worker`
# processes (1 slot each) on loopback; a Decay calibration (DE with a fixed seed) run alone,
# then submitted 300 times at once. Fails unless every one of the 300 succeeds with the
# reference's result (x_opt and f_opt bitwise, same evaluations). Prints the wall time, jobs/s,
# evaluations/s, the coordinator's peak RSS (VmHWM) and its RSS after the run, and a Markdown
# table for docs/src/benchmarks/service.md. Knobs: FMUCAL_LOAD_JOBS (300), FMUCAL_LOAD_WORKERS (4),
# FMUCAL_LOAD_POPULATION (16), FMUCAL_LOAD_GENERATIONS (500).
#   bash bench/load.sh
#   FMUCAL_LOAD_JOBS=30 FMUCAL_LOAD_WORKERS=2 bash bench/load.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo bench --locked --bench load
