# gRPC cases of bench/probe.sh (sourced): requests only a gRPC client or a worker can send,
# replayed by the bench binary bench/probe_grpc.rs against a coordinator started here (with a
# worker token of its own, and no worker: the binary starts one for its last case). Each line it
# prints, `CASE<TAB>PASS|FAIL<TAB>DETAIL`, is reported as a case of this script.

# The build's JSON lists every artifact it used (the fmucal binary too): take the bench's.
grpc_bin="$(cd "$ROOT" && cargo build --release --locked --bench probe_grpc --message-format=json 2>/dev/null |
    grep '"name":"probe_grpc"' | sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)"
if [ -z "$grpc_bin" ] || [ ! -x "$grpc_bin" ]; then
    report "grpc cases" FAIL "cannot build bench/probe_grpc.rs (cargo build --release --bench probe_grpc)"
else
    port="$(probe_port)"
    export FMUCAL_WORKER_TOKEN="probe-worker-token-9876543210"
    probe_start grpc -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$WORK/grpc"
    if probe_wait_healthy "http://127.0.0.1:$port"; then
        out="$WORK/grpc.out"
        FMUCAL="$FMUCAL" FMUCAL_PROBE_URL="http://127.0.0.1:$port" \
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
    unset FMUCAL_WORKER_TOKEN
fi
