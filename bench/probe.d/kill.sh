# Kills and damage, as bench/probe.sh cases (sourced): a local calibration killed with SIGKILL
# takes its workers with it and the next run removes its folder; Ctrl-C (SIGINT) writes the
# best point so far; a damaged job store is refused naming --salvage. Each check is reported
# with `report NAME PASS|FAIL DETAIL`.

kill_dir="$WORK/kill"
mkdir -p "$kill_dir"

# The fmucal processes whose parent is PID.
kill_children() {
    local d
    for d in /proc/[0-9]*; do
        [ "$(awk '/^PPid:/ { print $2 }' "$d/status" 2>/dev/null)" = "$1" ] || continue
        [ "$(readlink "$d/exe" 2>/dev/null)" = "$FMUCAL" ] && echo "${d#/proc/}"
    done
}

# A run long enough to be killed: the Furuta example with no tolerance to stop it early.
sed 's/^f_tol = .*/f_tol = 0.0/; s/^x_tol = .*/x_tol = 0.0/' "$EX/furuta/job.toml" >"$kill_dir/job.toml"
cp "$EX"/furuta/*.mat "$kill_dir"/ 2>/dev/null || true
"$FMUCAL" calibrate "$kill_dir/job.toml" --workers 2 --out "$kill_dir/out-kill" >"$kill_dir/kill.log" 2>&1 </dev/null &
run=$!
workers=""
# Its 2 workers are one worker process of 2 slots.
for i in $(seq 300); do
    workers="$(kill_children "$run")"
    [ "$(echo "$workers" | grep -c .)" -ge 1 ] && break
    sleep 0.1
done
folders_before="$(ls -d "$TMPDIR"/fmucal-run-* 2>/dev/null)"
kill -KILL "$run" 2>/dev/null
wait "$run" 2>/dev/null
left=""
for i in $(seq 50); do
    left=""
    for w in $workers; do kill -0 "$w" 2>/dev/null && left="$left $w"; done
    [ -z "$left" ] && break
    sleep 0.1
done
if [ -z "$workers" ]; then
    report "SIGKILL of calibrate: workers die with it" FAIL "no worker started within 30 s: $(head -c 200 "$kill_dir/kill.log")"
elif [ -n "$left" ]; then
    report "SIGKILL of calibrate: workers die with it" FAIL "still running 5 s later:$left"
    for w in $left; do kill -KILL "$w" 2>/dev/null; done
else
    report "SIGKILL of calibrate: workers die with it" PASS "$(echo $workers | wc -w) worker process(es) gone within $((i * 100)) ms"
fi
probe_works "the next run after a SIGKILL" -- "$FMUCAL" inspect example:decay
# inspect makes no run folder; a calibration does, and removes the dead run's first.
sed 's/^max_iters = .*//; s/^\[optimizer\]/[optimizer]\nmax_fevals = 10/' "$kill_dir/job.toml" >"$kill_dir/short.toml"
"$FMUCAL" calibrate "$kill_dir/short.toml" --workers 1 --out "$kill_dir/out-short" >"$kill_dir/short.log" 2>&1 </dev/null
still=""
for f in $folders_before; do [ -e "$f" ] && still="$still $f"; done
if [ -z "$folders_before" ]; then
    report "the next run removes a killed run's folder" FAIL "the killed run made no fmucal-run-* folder in $TMPDIR"
elif [ -n "$still" ]; then
    report "the next run removes a killed run's folder" FAIL "left:$still"
else
    report "the next run removes a killed run's folder" PASS "$(basename $folders_before) removed by the next calibration"
fi

# Ctrl-C: the best point so far, termination "interrupted", exit non-zero, nothing left.
"$FMUCAL" calibrate "$kill_dir/job.toml" --workers 2 --out "$kill_dir/out-int" >"$kill_dir/int.log" 2>&1 </dev/null &
run=$!
for i in $(seq 300); do
    grep -q "evaluations\|iteration\|f =" "$kill_dir/int.log" 2>/dev/null && break
    [ "$(kill_children "$run" | grep -c .)" -ge 1 ] && sleep 2 && break
    sleep 0.1
done
kill -INT "$run" 2>/dev/null
timeout 20 tail --pid="$run" -f /dev/null
wait "$run"
rc=$?
if [ "$rc" -eq 0 ]; then
    report "Ctrl-C of calibrate" FAIL "exit 0"
elif ! grep -q '"interrupted"' "$kill_dir/out-int/result.json" 2>/dev/null; then
    report "Ctrl-C of calibrate" FAIL "exit $rc, no result.json with termination interrupted: $(tail -n 1 "$kill_dir/int.log")"
else
    report "Ctrl-C of calibrate" PASS "exit $rc: $(grep -m1 interrupted "$kill_dir/int.log")"
fi

# A damaged store is refused naming --salvage. The store is the one the gRPC cases left (with
# their jobs), else a fresh one; its magic number is overwritten.
if [ -f "$WORK/grpc/jobs.redb" ]; then
    cp -r "$WORK/grpc" "$kill_dir/store"
else
    port="$(probe_port)"
    probe_start store -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$kill_dir/store"
    probe_wait_healthy "http://127.0.0.1:$port"
    probe_stop store
fi
db="$kill_dir/store/jobs.redb"
if [ -f "$db" ]; then
    printf 'garbage' | dd of="$db" bs=1 seek=0 conv=notrunc status=none
    probe_case "coordinator on a damaged store" --salvage -- \
        "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$kill_dir/store"
    # What --salvage gives back is asserted on a cleanly closed store by tests/hardening.rs
    # (salvage_gives_back_the_jobs_of_a_damaged_store): this store's last writer was stopped
    # by a signal, and how much of it still reads varies from run to run.
else
    report "coordinator on a damaged store" FAIL "no jobs.redb in $kill_dir/store"
fi
