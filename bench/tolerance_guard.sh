#!/usr/bin/env bash
# The integration-tolerance guard's cost and effect (shared/src/job/tolerance.rs): each job is
# calibrated with the guard (the default) and without it (`tolerance_guard = false`), and the
# table gives both wall times and evaluations, the guard's checks (simulations and seconds), its
# refit if it made one, the tolerance it ended at, and how far the guarded estimates moved, in
# the unguarded run's standard errors. Jobs: the paper's two examples (examples/furuta/job.toml,
# examples/exhaust/stage1_right.toml), and a stiff one: Robertson's reactions (example:robertson)
# with k1 and k3 on a log scale fitted to y1 and y3 made at rtol 1e-10 with 0.5 % noise.
#   bash bench/tolerance_guard.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked -q
F="$PWD/target/release/fmucal"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# The stiff job.
"$F" simulate example:robertson --stop-time 40 --output-interval 0.1 --tolerance 1e-10 \
  --output y1 --output y3 -o "$work/robertson_clean.csv" >/dev/null 2>&1
python3 - "$work/robertson_clean.csv" "$work/robertson.csv" <<'EOF'
import csv, random, sys
random.seed(11)
rows = list(csv.reader(open(sys.argv[1])))
cols = list(zip(*[[float(v) for v in r] for r in rows[1:]]))
sig = [0.005 * (max(c) - min(c)) for c in cols]
with open(sys.argv[2], "w") as f:
    f.write(",".join(rows[0]) + "\n")
    for r in rows[1:]:
        vals = [float(r[0])] + [float(v) + random.gauss(0, sig[i + 1]) for i, v in enumerate(r[1:])]
        f.write(",".join(repr(v) for v in vals) + "\n")
EOF
cat >"$work/robertson.toml" <<EOF
[model]
path = "example:robertson"
[data]
path = "$work/robertson.csv"
[[outputs]]
variable = "y1"
column = "y1"
[[outputs]]
variable = "y3"
column = "y3"
weight = 1.0
[[parameters]]
name = "k1"
start = 0.03
lower = 0.004
upper = 0.4
scale = "log"
[[parameters]]
name = "k3"
start = 20000.0
lower = 1000.0
upper = 100000.0
scale = "log"
[optimizer]
x_tol = 1e-6
f_tol = 1e-12
EOF

printf '| job | guard | wall s | evaluations | the check alone: s (of the unguarded run) | all checks: simulations, s | first-order move at the tighter tolerance: SE (parameter), refit | refit: evaluations, s | tolerance | largest move (SE) |\n'
printf '|---|---|---|---|---|---|---|---|---|---|\n'
for job in examples/furuta/job.toml examples/exhaust/stage1_right.toml "$work/robertson.toml"; do
  name="$(basename "$job" .toml)"
  off="$work/$name-off.toml"
  if grep -q '^\[simulation\]' "$job"; then
    sed 's/^\[simulation\]/[simulation]\ntolerance_guard = false/' "$job" >"$off"
  else
    { cat "$job"; printf '[simulation]\ntolerance_guard = false\n'; } >"$off"
  fi
  # Relative data paths resolve against the job's folder.
  cp "$off" "$(dirname "$job")/.guard-off-$name.toml"
  for mode in off on; do
    file="$job"
    [ "$mode" = off ] && file="$(dirname "$job")/.guard-off-$name.toml"
    start=$(date +%s.%N)
    "$F" calibrate "$file" --workers 2 --out "$work/$name-$mode" >"$work/$name-$mode.log" 2>&1
    end=$(date +%s.%N)
    echo "$start $end" >"$work/$name-$mode.time"
  done
  rm -f "$(dirname "$job")/.guard-off-$name.toml"
  python3 - "$work/$name" "$name" <<'EOF'
import json, sys
base, name = sys.argv[1], sys.argv[2]
def load(mode):
    r = json.load(open(f"{base}-{mode}/result.json"))
    t0, t1 = map(float, open(f"{base}-{mode}.time").read().split())
    return r, t1 - t0
off, t_off = load("off")
on, t_on = load("on")
ids = off.get("identifiability") or {}
names, se = ids.get("names", []), ids.get("standard_errors", [])
move = max((abs(on["x_opt"][n] - off["x_opt"][n]) / s for n, s in zip(names, se) if s and s == s), default=float("nan"))
g = on.get("tolerance_guard", {})
checks = g.get("checks", [])
# The check alone: the first check at the start point and the first at the optimum; the
# others re-check a tightened tolerance (part of the tightening and the refit).
first = [next((c for c in checks if c["at"] == at), None) for at in ("start", "optimum")]
alone = sum(c["seconds"] for c in first if c)
sims = sum(c["simulations"] for c in checks)
secs = sum(c["seconds"] for c in checks)
refit = g.get("refit")
refit_s = f'{refit["evaluations"]}, {refit["seconds"]:.2f}' if refit else "none"
# The guard's own first-order move (when the check at the optimum failed), and what the
# largest move of any parameter is as a fraction of x_tol, in the optimizer's scaled variables.
lm = g.get("linearised_move")
moved = "none"
if lm:
    moved = f'{lm["shift"]:.2f} ({lm["parameter"]}), refit {"needed" if lm["refit_needed"] else "not needed"} (x_tol {lm.get("x_tol")})'
print(f"| {name} | off | {t_off:.2f} | {off['evaluations']} | | | | | | |")
print(f"| {name} | on | {t_on:.2f} | {on['evaluations']} | {alone:.3f} ({100 * alone / t_off:.1f} %) | {sims}, {secs:.3f} | {moved} | {refit_s} | {g.get('tolerance')} | {move:.2f} |")
EOF
done
