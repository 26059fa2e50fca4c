#!/usr/bin/env bash
# Runtime benchmarks: fmucal against FMPy on the same FMUs and grids (FMI 2.0, and
# FMI 3.0 for Furuta), warm reset against a fresh instance, and RSS growth over 10,000
# reset-and-simulate cycles.
# Usage: bash bench/runtime.sh   (creates target/pyenv with FMPy on first use)
set -euo pipefail
cd "$(dirname "$0")/.."
py="$(bash tests/fmpy/ensure_venv.sh)"
out="$(mktemp -d)"
cargo bench --bench runtime -- --json "$out/fmucal.json"
furuta="$(cargo run --release -q -- examples | awk '$1=="furuta"{print $2}')"
ball="$(cargo run --release -q -- examples | awk '$1=="bouncing-ball"{print $2}')"
# The FMI 3.0 build of Furuta is a test fixture, not an example: the bench reports its path.
furuta3="$("$py" -c 'import json, sys; print(json.load(open(sys.argv[1]))["furuta_fmi3_fmu"])' "$out/fmucal.json")"
"$py" bench/fmpy_speed.py --fmu "$furuta" --stop 40 --interval 0.001 --repeat 3 > "$out/fmpy_furuta.json"
"$py" bench/fmpy_speed.py --fmu "$furuta3" --stop 40 --interval 0.001 --repeat 3 > "$out/fmpy_furuta3.json"
"$py" bench/fmpy_speed.py --fmu "$ball" --stop 3 --interval 0.001 --repeat 7 > "$out/fmpy_ball.json"
"$py" - "$out" <<'PY'
import json, sys, os
d = sys.argv[1]
f = json.load(open(os.path.join(d, "fmucal.json")))
fu = json.load(open(os.path.join(d, "fmpy_furuta.json")))
fu3 = json.load(open(os.path.join(d, "fmpy_furuta3.json")))
bb = json.load(open(os.path.join(d, "fmpy_ball.json")))
rows = [
    ("Furuta ME, 40 s, 1 ms grid", f["furuta_me_1ms_s"], fu["seconds"]),
    ("Furuta FMI 3.0 ME, 40 s, 1 ms grid", f["furuta_fmi3_me_1ms_s"], fu3["seconds"]),
    ("Bouncing ball ME, 3 s, 1 ms grid", f["bouncing_ball_me_1ms_s"], bb["seconds"]),
]
print("\n| simulation (rtol 1e-6) | fmucal [s] | FMPy [s] | fmucal / FMPy | target |")
print("|---|---|---|---|---|")
for name, a, b in rows:
    print(f"| {name} | {a:.4f} | {b:.4f} | {a / b:.3f} | <= 0.1 |")
print(f"\n| warm reset + simulate / fresh instance simulate | {f['warm_over_fresh']:.3f} | target <= 1.05 |")
print(f"| RSS growth over 10,000 reset-and-simulate cycles | {f['rss_growth_mb']:.2f} MB | target < 10 MB |")
PY
