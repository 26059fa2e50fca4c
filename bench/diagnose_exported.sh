#!/usr/bin/env bash
# The discrepancy-discovery grid on models as tools export them
# (tests/diagnosis_exported.rs, `full_grid`): the exported-shape bases without injection ports
# (SpringMassExported, FurutaExported, ExhaustPipeExported), hidden effects × noise 0.5, 1 and
# 2 % of each output's range × with and without a driving input, null cases, cases outside the
# effect library, and a few effects at 10 % noise; no job has a [diagnose] section. Each case
# writes seeded noisy data from a fixture FMU, runs `fmucal diagnose --workers 2` with the base
# FMU, reads its report and measures the gap against the noise-free truth on the held-out
# window. Prints one table row per case, the targets, and the summaries of the misses. Set
# DIAGNOSIS_GRID_DIR to keep the cases' folders (data, job, diagnosis/). Set
# DIAGNOSIS_GRID_CASES to a comma-separated list of case numbers to run only those, e.g.
#   DIAGNOSIS_GRID_DIR=/tmp/exported DIAGNOSIS_GRID_CASES=6,7,10 bash bench/diagnose_exported.sh
#   bash bench/diagnose_exported.sh
set -euo pipefail
exec bash "$(dirname "$0")/full_grid.sh" diagnosis_exported '^(\||target:|miss:|    )'
