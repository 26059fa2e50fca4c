# Service cases of bench/probe.sh (sourced): the coordinator's and worker's flags, the
# environment, the data dir, TLS, and a flood of held sockets. Servers listen on 127.0.0.1
# ports, keep their state in $WORK, and are stopped before the next group of cases.

# Durations and counts that make no sense.
for value in 0 -1 NaN inf 1e300 0.5; do
    probe_case "coordinator --worker-expiry $value" --worker-expiry -- \
        "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/c0" "--worker-expiry=$value"
done
for flag in --evaluation-timeout --idle-timeout --auth-timeout; do
    probe_case "coordinator $flag 0" "$flag" -- \
        "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/c0" "$flag=0"
done
for slots in 0 257 4000000000; do
    probe_case "worker --slots $slots" --slots -- \
        "$FMUCAL" worker --coordinator "http://127.0.0.1:9" --slots "$slots"
done
probe_case "health --timeout 0" --timeout -- "$FMUCAL" health http://127.0.0.1:9 --timeout 0
probe_case "health --timeout -1" --timeout -- "$FMUCAL" health http://127.0.0.1:9 --timeout=-1

probe_case "coordinator without a token" FMUCAL_TOKEN -- \
    env -u FMUCAL_TOKEN "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/c0"

# Health waits its whole --timeout (connecting included) for a server that never answers, a
# listener that accepts nothing, and then gives up (1.5 s of slack for starting the process).
silent_port="$(probe_port)"
python3 -c 'import socket, sys, time
s = socket.socket()
s.bind(("127.0.0.1", int(sys.argv[1])))
s.listen(16)
time.sleep(120)' "$silent_port" </dev/null >/dev/null 2>&1 &
silent=$!
sleep 0.5
health_start="$(date +%s%N)"
probe_case "health --timeout 4 on a server that never answers" "within 4 s" -- \
    "$FMUCAL" health "http://127.0.0.1:$silent_port" --timeout 4
health_ms=$((($(date +%s%N) - health_start) / 1000000))
if [ "$health_ms" -lt 3800 ]; then
    report "  ... after its whole --timeout" FAIL "gave up after $health_ms ms, before its --timeout of 4 s"
elif [ "$health_ms" -gt 5500 ]; then
    report "  ... after its whole --timeout" FAIL "gave up after $health_ms ms, well past its --timeout of 4 s"
else
    report "  ... after its whole --timeout" PASS "gave up after $health_ms ms"
fi
kill "$silent" 2>/dev/null
wait "$silent" 2>/dev/null

# Environment values are refused, not ignored.
probe_case "FMUCAL_MAX_UNPACK_BYTES=abc" FMUCAL_MAX_UNPACK_BYTES -- \
    env FMUCAL_MAX_UNPACK_BYTES=abc "$FMUCAL" inspect example:decay
probe_case "FMUCAL_MAX_UNPACK_ENTRIES=-1" FMUCAL_MAX_UNPACK_ENTRIES -- \
    env FMUCAL_MAX_UNPACK_ENTRIES=-1 "$FMUCAL" inspect example:decay
probe_case "FMUCAL_LOG=[[[" FMUCAL_LOG -- env 'FMUCAL_LOG=[[[' "$FMUCAL" inspect example:decay

# The data dir: a file, and one in use by another coordinator (refused before "listening").
cp /etc/passwd "$WORK/passwd" 2>/dev/null || echo "root:x:0:0" >"$WORK/passwd"
probe_case "coordinator --data-dir a file" "$WORK/passwd" -- \
    "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/passwd"
port="$(probe_port)"
probe_start held -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$WORK/held"
probe_wait_healthy "http://127.0.0.1:$port"
probe_case "coordinator on a data dir in use" "in use" -- \
    "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/held"
if grep -q listening "$WORK/case.out"; then
    report "  ... and says nothing of listening" FAIL "$(grep -m1 listening "$WORK/case.out")"
fi

# A flood of held sockets (1,100, with --max-connections 64; fewer if this shell may not open
# that many descriptors): health answers within its --timeout, and so does a client with a
# token (a calibration on a worker that registered before the flood). Their times are shown,
# not asserted.
port="$(probe_port)"
probe_start flooded -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$WORK/flooded" --max-connections 64
probe_wait_healthy "http://127.0.0.1:$port"
flood_dir="$WORK/flood"
mkdir -p "$flood_dir"
awk 'BEGIN { print "time,x"; for (i = 0; i <= 200; i++) { t = i * 0.01; printf "%g,%.12g\n", t, exp(-1.7 * t) } }' \
    >"$flood_dir/decay.csv"
cat >"$flood_dir/job.toml" <<'TOML'
[model]
path = "example:decay"
[data]
path = "decay.csv"
[[outputs]]
variable = "x"
column = "x"
[[parameters]]
name = "k"
start = 1.0
lower = 0.5
upper = 3.0
[simulation]
stop_time = 2.0
TOML
probe_start flood-worker -- "$FMUCAL" worker --coordinator "http://127.0.0.1:$port"
probe_works "calibrate --coordinator before the flood" -- \
    "$FMUCAL" calibrate "$flood_dir/job.toml" --coordinator "http://127.0.0.1:$port" --out "$flood_dir/out0"
flood_target=1100
fd_room=$(($(ulimit -n) - 64))
[ "$fd_room" -lt "$flood_target" ] && flood_target="$fd_room"
flood=()
for i in $(seq "$flood_target"); do
    exec {fd}<>"/dev/tcp/127.0.0.1/$port" 2>/dev/null && flood+=("$fd")
done
probe_works "health under a flood of ${#flood[@]} held sockets" -- \
    "$FMUCAL" health "http://127.0.0.1:$port" --timeout 5
probe_works "health under the flood, again" -- "$FMUCAL" health "http://127.0.0.1:$port" --timeout 5
probe_works "calibrate --coordinator under the flood" -- \
    "$FMUCAL" calibrate "$flood_dir/job.toml" --coordinator "http://127.0.0.1:$port" --out "$flood_dir/out1"
probe_works "health under the flood, after the calibration" -- \
    "$FMUCAL" health "http://127.0.0.1:$port" --timeout 5
for fd in "${flood[@]}"; do
    exec {fd}>&-
done
probe_stop flood-worker
# Ordinary jobs (with their standard-error follow-up) log no warning about results: a late
# result is normal, logged at debug.
warned="$(grep -E 'WARN.*(result|leased)' "$WORK/flooded.log" | head -n 1)"
if [ -n "$warned" ]; then
    report "no WARN about results after ordinary jobs" FAIL "$warned"
else
    report "no WARN about results after ordinary jobs" PASS "$(grep -c WARN "$WORK/flooded.log") WARN lines in all, none about results"
fi
probe_stop flooded
probe_stop held

# TLS: a key that is not the certificate's, a file that holds no certificate, a worker that
# trusts another CA, a plaintext client of a TLS coordinator.
"$FMUCAL" certs --out "$WORK/certs" >/dev/null 2>&1
"$FMUCAL" certs --out "$WORK/other-certs" >/dev/null 2>&1
printf -- '-----BEGIN CERTIFICATE-----\nnot base64!\n-----END CERTIFICATE-----\n' >"$WORK/garbage.pem"
probe_case "coordinator with another certificate's key" client-key.pem -- \
    "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/tls0" \
    --tls-cert "$WORK/certs/coordinator.pem" --tls-key "$WORK/certs/client-key.pem"
probe_case "coordinator with a garbage certificate" garbage.pem -- \
    "$FMUCAL" coordinator --listen "127.0.0.1:$(probe_port)" --data-dir "$WORK/tls0" \
    --tls-cert "$WORK/garbage.pem" --tls-key "$WORK/certs/coordinator-key.pem"
port="$(probe_port)"
probe_start tls -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$WORK/tls" \
    --tls-cert "$WORK/certs/coordinator.pem" --tls-key "$WORK/certs/coordinator-key.pem"
probe_wait_healthy "https://localhost:$port" --tls-ca "$WORK/certs/ca.pem"
for i in 1 2 3; do
    probe_case "health http:// to a TLS coordinator ($i)" TLS -- "$FMUCAL" health "http://127.0.0.1:$port"
done
probe_case "worker http:// to a TLS coordinator" TLS -- "$FMUCAL" worker --coordinator "http://127.0.0.1:$port"
probe_case "worker trusting another CA" "$WORK/other-certs/ca.pem" -- \
    "$FMUCAL" worker --coordinator "https://localhost:$port" --tls-ca "$WORK/other-certs/ca.pem"
probe_case "worker with a garbage CA file" garbage.pem -- \
    "$FMUCAL" worker --coordinator "https://localhost:$port" --tls-ca "$WORK/garbage.pem"
probe_stop tls

# A truncated .mat data file is called truncated.
mkdir -p "$WORK/mat"
head -c 60000 "$EX/furuta/FurutaData.mat" >"$WORK/mat/FurutaData.mat"
sed 's|^path = "FurutaData.mat".*|path = "FurutaData.mat"|' "$EX/furuta/job.toml" >"$WORK/mat/job.toml"
probe_case "calibrate on a truncated .mat file" truncated -- \
    "$FMUCAL" calibrate "$WORK/mat/job.toml" --workers 1 --out "$WORK/mat/out"
