# gRPC cases of bench/probe.sh (sourced): requests only a gRPC client or a worker can send,
# replayed by the bench binary bench/probe_grpc.rs against a coordinator started here (with a
# worker token of its own, and no worker: the binary starts one for its last cases). Then the
# process-level cases of bench/probe_processes.rs, for which the binary starts, kills and
# restarts its own servers: a model file gone at restart, a model that never returns, a SIGKILL
# of the coordinator during a Diagnose call, and a data dir on a disk that fills up. Each line
# it prints, `CASE<TAB>PASS|FAIL<TAB>DETAIL`, is reported as a case of this script.

# The build's JSON lists every artifact it used (the fmucal binary too): take the bench's.
grpc_bin="$(cd "$ROOT" && cargo build --release --locked --bench probe_grpc --message-format=json 2>/dev/null |
    grep '"name":"probe_grpc"' | sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)"
# grpc_scenario WHAT MODE DIR [PREFIX...]: runs `PREFIX... $grpc_bin MODE DIR` and reports its
# lines (the binary starts its own servers for these).
grpc_scenario() {
    local what="$1" mode="$2" dir="$3" out="$WORK/$2.out" rc
    shift 3
    mkdir -p "$dir"
    FMUCAL="$FMUCAL" timeout --kill-after=5 300 "$@" "$grpc_bin" "$mode" "$dir" >"$out" 2>"$WORK/$mode.err" </dev/null
    rc=$?
    while IFS=$'\t' read -r name verdict detail; do
        report "$name" "$verdict" "$detail"
    done <"$out"
    if [ "$rc" -ne 0 ]; then
        report "$what ran to their end" FAIL "exit $rc: $(grep -m1 -v '^[[:space:]]*$' "$WORK/$mode.err")"
    fi
}

if [ -z "$grpc_bin" ] || [ ! -x "$grpc_bin" ]; then
    report "grpc cases" FAIL "cannot build bench/probe_grpc.rs (cargo build --release --bench probe_grpc)"
else
    port="$(probe_port)"
    export FMUCAL_WORKER_TOKEN="probe-worker-token-9876543210"
    probe_start grpc -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$WORK/grpc"
    if probe_wait_healthy "http://127.0.0.1:$port"; then
        out="$WORK/grpc.out"
        FMUCAL="$FMUCAL" FMUCAL_PROBE_URL="http://127.0.0.1:$port" FMUCAL_PROBE_DATA_DIR="$WORK/grpc" \
            FMUCAL_PROBE_COORDINATOR_PID="${servers[grpc]}" \
            timeout --kill-after=5 300 "$grpc_bin" >"$out" 2>"$WORK/grpc.err" </dev/null
        rc=$?
        while IFS=$'\t' read -r name verdict detail; do
            report "$name" "$verdict" "$detail"
        done <"$out"
        if [ "$rc" -ne 0 ]; then
            report "grpc cases ran to their end" FAIL "exit $rc: $(grep -m1 -v '^[[:space:]]*$' "$WORK/grpc.err")"
        fi
    else
        report "grpc coordinator" FAIL "did not become healthy: $(tail -n 1 "$WORK/grpc.log")"
    fi
    probe_stop grpc

    # Process-level cases: the binary starts, kills, restarts and hangs its own coordinators
    # and workers under $WORK/processes (a model file gone at restart, a model that never
    # returns, a SIGKILL of the coordinator during a Diagnose call).
    grpc_scenario "process cases" processes "$WORK/processes"

    # A data dir on a disk that fills up: a 32 MB tmpfs, mounted in a mount namespace of the
    # binary's own (unshare -m as root, else in a user namespace), so that ENOSPC comes from
    # the kernel and the mount goes with the last process using it.
    disk="$WORK/disk"
    mkdir -p "$disk"
    ns=()
    for try in "unshare -m --propagation private" "unshare -rm --propagation private"; do
        # shellcheck disable=SC2086
        if $try sh -c 'mount -t tmpfs -o size=1m probe "$1"' sh "$disk" 2>/dev/null; then
            read -ra ns <<<"$try"
            break
        fi
    done
    if [ "${#ns[@]}" -eq 0 ]; then
        report "full disk" FAIL "cannot mount a small tmpfs: unshare -m needs root or user namespaces"
    else
        grpc_scenario "full disk cases" full-disk "$disk" "${ns[@]}" \
            sh -c 'mount -t tmpfs -o size=32m fmucal-probe "$1" && shift && exec "$@"' sh "$disk"
    fi
    unset FMUCAL_WORKER_TOKEN
fi
