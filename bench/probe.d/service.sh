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

# A flood of held sockets (600, with --max-connections 64): health answers within its
# --timeout, and the time it took is shown.
port="$(probe_port)"
probe_start flooded -- "$FMUCAL" coordinator --listen "127.0.0.1:$port" --data-dir "$WORK/flooded" --max-connections 64
probe_wait_healthy "http://127.0.0.1:$port"
flood=()
for i in $(seq 600); do
    exec {fd}<>"/dev/tcp/127.0.0.1/$port" 2>/dev/null && flood+=("$fd")
done
probe_works "health under a flood of ${#flood[@]} held sockets" -- \
    "$FMUCAL" health "http://127.0.0.1:$port" --timeout 5
probe_works "health under the flood, again" -- "$FMUCAL" health "http://127.0.0.1:$port" --timeout 5
for fd in "${flood[@]}"; do
    exec {fd}>&-
done
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
