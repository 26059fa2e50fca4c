#!/usr/bin/env bash
# The long run of tests/fuzz_parsers.rs: the job-file, modelDescription.xml and FMU-archive
# mutation fuzzers, each for FMUCAL_FUZZ_SECONDS (default 1200, an hour for the three), from
# their fixed seed. A panicking input fails the run and is saved under target/tmp/fuzz-failures/.
#   bash bench/fuzz.sh            # an hour
#   FMUCAL_FUZZ_SECONDS=60 bash bench/fuzz.sh
set -euo pipefail
cd "$(dirname "$0")/.."
export FMUCAL_FUZZ_SECONDS=${FMUCAL_FUZZ_SECONDS:-1200}
cargo test --release --locked --test fuzz_parsers -- --nocapture --test-threads 1 2>&1 \
  | grep -E "inputs in|test result|panicked|saved to"
