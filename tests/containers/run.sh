#!/usr/bin/env bash
# The container test: deploy/compose.yaml run for real, with TLS and the two tokens,
# on an image built here (tests/containers/build_image.sh: the Dockerfile's runtime stage on a
# locally made Debian root filesystem, as no registry can be reached). It checks that
#   0. `fmucal export` works in the image (its FMU runtime is beside the binary);
#   1. a calibration submitted from the host gives exactly the local result;
#   2. workers added with `up --scale worker=4` during a running job take points;
#   3. a worker killed with `docker kill` mid-job,
#   4. and a worker cut off the network (`docker network disconnect`) and back, leave the
#      result unchanged, with nothing told twice once the partition heals;
#   5. a coordinator container restarted mid-job (its volume kept) resumes the job, and the
#      client that submitted it gets the unchanged result;
# and prints the figures (time to scale out, results ignored after the partition).
# Run by .ci/run; skipped with one line when no Docker engine answers. Needs
# target/release/fmucal (BIN overrides), root for debootstrap the first time, and ports
# FMUCAL_PORT (17070) and FMUCAL_METRICS_PORT (19090) free on 127.0.0.1.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
bin="${BIN:-$repo/target/release/fmucal}"

say() { echo "containers: $*"; }
if ! docker info >/dev/null 2>&1; then
  say "skipped: no Docker engine answers (docker info failed)"
  exit 0
fi
if ! docker image inspect fmucal-base:bookworm >/dev/null 2>&1 && [ "$(id -u)" != 0 ]; then
  say "skipped: the base image fmucal-base:bookworm is not there and making it (debootstrap) needs root"
  exit 0
fi
if docker compose version >/dev/null 2>&1; then compose_cmd=(docker compose); else compose_cmd=(docker-compose); fi

export FMUCAL_PORT="${FMUCAL_PORT:-17070}" FMUCAL_METRICS_PORT="${FMUCAL_METRICS_PORT:-19090}"
export FMUCAL_TOKEN FMUCAL_WORKER_TOKEN
FMUCAL_TOKEN="$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')"
FMUCAL_WORKER_TOKEN="$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')"
project="fmucal-ct-$$"
work="$(mktemp -d)"
url="https://localhost:$FMUCAL_PORT"
metrics_url="http://127.0.0.1:$FMUCAL_METRICS_PORT/metrics"
compose() { "${compose_cmd[@]}" -p "$project" -f "$repo/deploy/compose.yaml" "$@"; }
cleanup() {
  if [ "${KEEP:-0}" != 1 ]; then
    compose down -v --remove-orphans >/dev/null 2>&1 || true
    rm -rf "$work"
  else
    say "kept project $project and $work (KEEP=1)"
  fi
}
trap cleanup EXIT

passed=0
failed=0
pass() { passed=$((passed + 1)); echo "ok - $*"; }
fail() { failed=$((failed + 1)); echo "FAIL - $*"; }
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

# A metric's value from a Prometheus text page (0 when absent or unreachable).
metric() { { curl -sf --max-time 2 "${2:-$metrics_url}" || true; } | awk -v n="$1" '$1 == n { v = $2 } END { print v + 0 }'; }
worker_ids() { compose ps -q worker | sort; }
ip_of() { docker inspect -f '{{range .NetworkSettings.Networks}}{{.IPAddress}}{{end}}' "$1"; }
# Waits up to $2 seconds for the command $1 to succeed.
wait_for() {
  local deadline=$(($(date +%s) + $2))
  until eval "$1"; do
    [ "$(date +%s)" -lt "$deadline" ] || return 1
    sleep 0.2
  done
}
# Whether two result.json files have the same x_opt, f_opt, evaluations and rounds, to the bit.
same_result() {
  python3 - "$1" "$2" <<'EOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
keys = ["x_opt", "f_opt", "evaluations", "rounds", "iterations", "failed_evaluations"]
diff = [f"{k}: {a.get(k)!r} != {b.get(k)!r}" for k in keys if a.get(k) != b.get(k)]
print("; ".join(diff) if diff else f"x_opt {a['x_opt']}, f_opt {a['f_opt']!r}, {a['evaluations']} evaluations")
sys.exit(1 if diff else 0)
EOF
}
# Submits the long job from the host in the background, into $work/$1 (its pid in $client, the
# results the pool had told before in $told_before), and waits up to 120 s until the pool has
# told $2 more.
submit_long() {
  told_before="$(metric fmucal_evaluations_total)"
  "$bin" calibrate "$here/long_job.toml" --coordinator "$url" --out "$work/$1" >/dev/null 2>"$work/$1.log" &
  client=$!
  wait_for "[ \$(metric fmucal_evaluations_total) -gt $((told_before + $2)) ]" 120
}
evaluations_of() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["evaluations"])' "$1"; }
# What a calibration adds to the results the coordinator told beyond its own evaluations: the
# points of the tolerance guard's first-order move at the optimum (when its check there failed),
# and the 2n + 1 identifiability points, unless the move's points gave the standard errors
# (no refit followed).
extra_of() {
  python3 - "$1" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
moved = (r.get("tolerance_guard") or {}).get("linearised_move")
extra = moved["simulations"] if moved else 0
if not (moved and not moved["refit_needed"]):
    extra += 2 * len(r["x_opt"]) + 1
print(extra)
EOF
}

say "building the image"
start="$(now)"
BIN="$bin" bash "$here/build_image.sh" >/dev/null
say "image fmucal:latest built in $(since "$start") s"

# 0. The image exports: `fmucal export` in the container finds the FMU runtime beside the binary.
if docker run --rm -v "$repo/examples/friction:/job:ro" fmucal:latest \
     export /job/job.toml -o /var/lib/fmucal/corrected.fmu >"$work/export.log" 2>&1 \
   && grep -q "FMI 2.0" "$work/export.log"; then
  pass "fmucal export in the image: $(head -c 100 "$work/export.log")"
else
  cat "$work/export.log"
  fail "fmucal export in the image"
fi

# References: the same jobs with local worker processes (no containers).
"$bin" calibrate "$repo/examples/furuta/job.toml" --out "$work/local-furuta" >/dev/null 2>"$work/local-furuta.log"
start="$(now)"
"$bin" calibrate "$here/long_job.toml" --out "$work/local-long" >/dev/null 2>"$work/local-long.log"
say "the long job's local reference took $(since "$start") s ($(evaluations_of "$work/local-long/result.json") evaluations)"

start="$(now)"
compose up -d --no-build --scale worker=2 2>"$work/up.log" || { cat "$work/up.log"; exit 1; }
coordinator="$(compose ps -q coordinator)"
wait_for "docker cp '$coordinator:/certs/ca.pem' '$work/ca.pem' 2>/dev/null" 60 || { say "no CA in the coordinator"; exit 1; }
export FMUCAL_TLS_CA="$work/ca.pem"
wait_for "'$bin' health '$url' >/dev/null 2>&1" 60 || { compose logs coordinator; exit 1; }
wait_for "[ \$(metric fmucal_workers) -eq 2 ]" 60 || { compose logs; exit 1; }
say "coordinator and 2 workers up in $(since "$start") s"

# 1. From the host, over TLS, with the client token: exactly the local result.
"$bin" calibrate "$repo/examples/furuta/job.toml" --coordinator "$url" --out "$work/remote-furuta" \
  >/dev/null 2>"$work/remote-furuta.log" || { cat "$work/remote-furuta.log"; fail "furuta on the pool"; }
if why="$(same_result "$work/local-furuta/result.json" "$work/remote-furuta/result.json")"; then
  pass "a calibration submitted from the host gives exactly the local result ($why)"
else
  fail "the pool's Furuta result differs from the local one: $why"
fi

# 2.-4. The long job, while the pool grows, loses a worker and has one cut off.
ignored_before="$(metric fmucal_late_results_total)"
submit_long remote-long 100 || fail "the long job did not start"
first_two="$(worker_ids)"
start="$(now)"
compose up -d --no-build --scale worker=4 2>>"$work/up.log"
wait_for "[ \$(metric fmucal_workers) -eq 4 ]" 60 && registered="$(since "$start")" || registered="never"
new_workers="$(comm -13 <(echo "$first_two") <(worker_ids))"
busy() { for w in $new_workers; do [ "$(metric fmucal_worker_evaluations_total "http://$(ip_of "$w"):9091/metrics")" -gt 0 ] || return 1; done; }
if [ "$(echo "$new_workers" | wc -w)" -eq 2 ] && wait_for busy 60; then
  pass "up --scale worker=4 mid-job: 4 workers registered after $registered s, both new ones evaluating after $(since "$start") s"
  scale_out="$(since "$start")"
else
  fail "the new workers did not take points (registered: $registered)"
fi
# The first line of each list, without a pipe: under pipefail `echo | head -1` can die of
# SIGPIPE (bash writes line by line, head exits after the first).
victim="${first_two%%$'\n'*}"
docker kill "$victim" >/dev/null
say "killed worker ${victim:0:12}"
sleep 2
cut="${new_workers%%$'\n'*}"
network="$(docker inspect -f '{{range $k, $v := .NetworkSettings.Networks}}{{$k}}{{end}}' "$cut")"
docker network disconnect "$network" "$cut"
say "cut worker ${cut:0:12} off $network for 12 s (the coordinator expires it after 5 s)"
sleep 12
docker network connect "$network" "$cut"
healed="$(now)"
cut_metrics="http://$(ip_of "$cut"):9091/metrics"
if wait_for "[ \$(metric fmucal_workers) -ge 3 ]" 60; then
  say "worker ${cut:0:12} registered again $(since "$healed") s after the partition healed"
else
  fail "the cut-off worker did not come back"
fi
cut_done_at_heal="$(metric fmucal_worker_evaluations_total "$cut_metrics")"
if wait "$client"; then
  if why="$(same_result "$work/local-long/result.json" "$work/remote-long/result.json")"; then
    pass "scaled to 4, one worker killed, one partitioned and back: the result is unchanged ($why)"
  else
    fail "the long job's result changed: $why"
  fi
  told=$(($(metric fmucal_evaluations_total) - told_before))
  expected=$(($(evaluations_of "$work/remote-long/result.json") + $(extra_of "$work/remote-long/result.json")))
  ignored=$(($(metric fmucal_late_results_total) - ignored_before))
  cut_after_heal=$(($(metric fmucal_worker_evaluations_total "$cut_metrics") - cut_done_at_heal))
  if [ "$told" -eq "$expected" ]; then
    pass "nothing told twice: $told results taken for $expected evaluations; $ignored late results of the cut-off worker ignored; it evaluated $cut_after_heal new points after it came back"
  else
    fail "$told results taken for $expected evaluations ($ignored ignored)"
  fi
else
  cat "$work/remote-long.log"
  fail "the long job failed on a pool that grew, lost a worker and had one partitioned"
fi

# 5. The coordinator container restarted mid-job: the job resumes from its store.
submit_long restarted 500 || fail "the second long job did not start"
start="$(now)"
compose restart -t 10 coordinator >/dev/null 2>&1
wait_for "'$bin' health '$url' >/dev/null 2>&1" 60 || fail "the coordinator did not come back"
back="$(since "$start")"
if wait "$client"; then
  if why="$(same_result "$work/local-long/result.json" "$work/restarted/result.json")"; then
    pass "coordinator restarted mid-job (serving again after $back s): the job resumed to the same result ($why)"
  else
    fail "the job resumed after a coordinator restart ended differently: $why"
  fi
else
  cat "$work/restarted.log"
  fail "the client lost the job across the coordinator's restart"
fi
grep -q "lost the coordinator" "$work/restarted.log" && say "the client followed the job again after the restart"

say "figures: scale-out to 4 workers ${scale_out:-?} s, coordinator back after ${back:-?} s"
echo "test result: $([ "$failed" -eq 0 ] && echo ok || echo FAILED). $passed passed; $failed failed (containers)"
[ "$failed" -eq 0 ]
