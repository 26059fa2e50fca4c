#!/usr/bin/env bash
# Paired, interleaved comparison of the runtime benchmark (bench/runtime.rs) between an earlier
# build and this working tree: builds both bench binaries, runs them alternately RUNS times
# (the order flips every round, so drift in the machine's load hits both alike), and prints the
# median of each timing and the ratio new / base.
# Usage: bash bench/runtime_paired.sh BASE_REV [RUNS]   (RUNS defaults to 5)
set -euo pipefail
cd "$(dirname "$0")/.."
base="${1:?usage: bash bench/runtime_paired.sh BASE_REV [RUNS]}"
runs="${2:-5}"
case "$runs" in ''|*[!0-9]*) echo "RUNS must be a whole number, got $runs" >&2; exit 2 ;; esac
if [ "$runs" -lt 1 ] || [ "$runs" -gt 100 ]; then echo "RUNS must be 1 to 100, got $runs" >&2; exit 2; fi
repo="$(pwd)"
work="$(mktemp -d)"
cleanup() { git -C "$repo" worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"; }
trap cleanup EXIT
git worktree add --detach "$work/base" "$base" >/dev/null
bench_binary() { # the runtime bench executable cargo builds in folder $1 with target dir $2
  (cd "$1" && CARGO_TARGET_DIR="$2" cargo bench --bench runtime --no-run --message-format=json 2>/dev/null) |
    python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "runtime" and m.get("executable"):
        print(m["executable"])'
}
echo "building the base ($base) and this tree ..." >&2
old="$(bench_binary "$work/base" "$repo/target/paired-base")"
new="$(bench_binary "$repo" "$repo/target")"
[ -x "$old" ] && [ -x "$new" ] || { echo "a bench binary was not built" >&2; exit 1; }
for i in $(seq 1 "$runs"); do
  if [ $((i % 2)) = 1 ]; then order="old new"; else order="new old"; fi
  for which in $order; do
    bin="$old"; [ "$which" = new ] && bin="$new"
    "$bin" --json "$work/$which-$i.json" >/dev/null 2>&1
  done
  echo "round $i of $runs done" >&2
done
python3 - "$work" "$runs" "$base" <<'PY'
import json, os, statistics, sys
d, runs, base = sys.argv[1], int(sys.argv[2]), sys.argv[3]
load = lambda w: [json.load(open(os.path.join(d, f"{w}-{i}.json"))) for i in range(1, runs + 1)]
old, new = load("old"), load("new")
keys = [k for k, v in old[0].items() if isinstance(v, (int, float)) and k.endswith("_s")]
print(f"\n| timing (median of {runs} interleaved runs) | base {base} [s] | this tree [s] | this / base |")
print("|---|---|---|---|")
for k in keys:
    a = statistics.median(r[k] for r in old)
    b = statistics.median(r[k] for r in new)
    print(f"| {k} | {a:.4f} | {b:.4f} | {b / a:.3f} |")
PY
