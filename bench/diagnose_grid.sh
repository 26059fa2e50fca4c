#!/usr/bin/env bash
# The full discrepancy-discovery grid (tests/diagnosis_grid.rs, `full_grid`): every
# hidden effect and the null set × noise 0.5, 1 and 2 % of each output's range × input profiles,
# plus each effect at 10 % noise. Each case writes seeded noisy data from a fixture FMU whose C
# code holds the effect, runs `fmucal diagnose --workers 2` with the base FMU, and reads its
# report. Prints one table row per case and the targets. Set DIAGNOSIS_GRID_DIR to keep the
# cases' folders (data, job, diagnosis/). Set DIAGNOSIS_GRID_CASES to a comma-separated list of
# case numbers (the table's first column, the kept folders' caseNN) to run only those, e.g.
#   DIAGNOSIS_GRID_DIR=/tmp/gridcases DIAGNOSIS_GRID_CASES=6,7,10 bash bench/diagnose_grid.sh
#   bash bench/diagnose_grid.sh
set -euo pipefail
exec bash "$(dirname "$0")/full_grid.sh" diagnosis_grid '^(\||true effect|no effect found on|validation RMS above|raw validation RMS|at 10 %)'
