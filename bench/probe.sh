#!/usr/bin/env bash
# Replays hostile and careless inputs against the release binary, target/release/fmucal (it
# builds nothing: run `cargo build --release` first). Each case runs one command that must be
# refused: it passes if the command exits non-zero by itself (not by a signal, not by the
# time limit), prints no panic, and its output names the field (or flag, variable, file) the
# case gives. One line per case: its name, PASS or FAIL, and the first line of the error.
#
# The cases live in bench/probe.d/*.sh, sourced in turn, with:
#   $FMUCAL   the binary          $WORK  a scratch folder, removed at exit
#   $EX       the repo's examples/
#   probe_case NAME FIELD -- CMD ARGS...   a command that must be refused naming FIELD
#   probe_works NAME -- CMD ARGS...        a command that must succeed (its time is shown)
#   probe_start NAME -- CMD ARGS...        starts a server in the background (log $WORK/NAME.log)
#   probe_stop NAME                        stops it (SIGTERM, then SIGKILL)
#   probe_port                             prints a free 127.0.0.1 port
#   probe_wait_healthy URL [ARGS...]       waits until `fmucal health URL ARGS` answers SERVING
# At the end it checks that no process it started is left running and that nothing was
# written outside $WORK (fmucal's cache and temporary folders point into it; the repository's
# files must be unchanged), prints `N passed, N failed`, and exits non-zero on any failure.
#   bash bench/probe.sh            (about a minute; PROBE_TIMEOUT=60 s per case)
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT="$(pwd -P)"
FMUCAL="$ROOT/target/release/fmucal"
EX="$ROOT/examples"
if [ ! -x "$FMUCAL" ]; then
    echo "bench/probe.sh: $FMUCAL is missing: build it first (cargo build --release)" >&2
    exit 2
fi
WORK="$(mktemp -d "${TMPDIR:-/tmp}/fmucal-probe.XXXXXX")"
PROBE_TIMEOUT="${PROBE_TIMEOUT:-60}"
# Every process a case starts carries this marker, so the check at the end finds exactly
# ours; fmucal's cache and temporary folders go into $WORK.
export FMUCAL_PROBE_RUN="$WORK"
export FMUCAL_CACHE_DIR="$WORK/cache"
export TMPDIR="$WORK/tmp"
export FMUCAL_TOKEN="probe-client-token-0123456789"
unset FMUCAL_WORKER_TOKEN FMUCAL_TLS_CA FMUCAL_TLS_CERT FMUCAL_TLS_KEY FMUCAL_LOG \
    FMUCAL_MAX_UNPACK_BYTES FMUCAL_MAX_UNPACK_ENTRIES
mkdir -p "$TMPDIR" "$FMUCAL_CACHE_DIR"

passed=0
failed=0
declare -A servers=()

# The processes carrying this run's marker (this script's own shell and subshells aside).
probe_processes() {
    local d pid
    for d in /proc/[0-9]*; do
        pid="${d#/proc/}"
        [ "$pid" = "$$" ] && continue
        [ "$(readlink "$d/exe" 2>/dev/null)" = "$FMUCAL" ] || continue
        tr '\0' '\n' <"$d/environ" 2>/dev/null | grep -qxF "FMUCAL_PROBE_RUN=$WORK" && echo "$pid"
    done
}

repo_state() {
    git -C "$ROOT" status --porcelain --untracked-files=all 2>/dev/null | grep -v '^?? target/' || true
}
repo_before="$(repo_state)"

cleanup() {
    local name
    for name in "${!servers[@]}"; do
        probe_stop "$name"
    done
    rm -rf "$WORK"
}
trap cleanup EXIT

# Reports one case: NAME, PASS/FAIL, a line of detail.
report() {
    local name="$1" verdict="$2" detail="$3"
    printf '%-44s %-4s  %s\n' "$name" "$verdict" "${detail:0:150}"
    if [ "$verdict" = PASS ]; then passed=$((passed + 1)); else failed=$((failed + 1)); fi
}

probe_case() {
    local name="$1" field="$2"
    shift 2
    [ "${1:-}" = "--" ] && shift
    local out="$WORK/case.out" rc first
    timeout --kill-after=5 "$PROBE_TIMEOUT" "$@" >"$out" 2>&1 </dev/null
    rc=$?
    first="$(grep -m1 -v '^[[:space:]]*$' "$out" | tr -d '\r')"
    if [ "$rc" -eq 0 ]; then
        report "$name" FAIL "accepted (exit 0): $first"
    elif [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
        report "$name" FAIL "hung: still running after ${PROBE_TIMEOUT} s"
    elif [ "$rc" -gt 128 ]; then
        report "$name" FAIL "killed by signal $((rc - 128)): $first"
    elif grep -q "panicked" "$out"; then
        report "$name" FAIL "panicked: $(grep -m1 panicked "$out")"
    elif ! grep -qF -- "$field" "$out"; then
        report "$name" FAIL "does not name '$field': $first"
    else
        report "$name" PASS "$first"
    fi
}

probe_works() {
    local name="$1"
    shift
    [ "${1:-}" = "--" ] && shift
    local out="$WORK/case.out" rc start ms
    start="$(date +%s%N)"
    timeout --kill-after=5 "$PROBE_TIMEOUT" "$@" >"$out" 2>&1 </dev/null
    rc=$?
    ms=$((($(date +%s%N) - start) / 1000000))
    if [ "$rc" -eq 0 ] && ! grep -q "panicked" "$out"; then
        report "$name" PASS "ok in $ms ms: $(grep -m1 -v '^[[:space:]]*$' "$out")"
    else
        report "$name" FAIL "exit $rc after $ms ms: $(grep -m1 -v '^[[:space:]]*$' "$out")"
    fi
}

probe_start() {
    local name="$1"
    shift
    [ "${1:-}" = "--" ] && shift
    "$@" >"$WORK/$name.log" 2>&1 </dev/null &
    servers[$name]=$!
}

probe_stop() {
    local name="$1" pid="${servers[$1]:-}" i
    [ -n "$pid" ] || return 0
    kill -TERM "$pid" 2>/dev/null
    for i in $(seq 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
    done
    kill -KILL "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
    unset "servers[$name]"
}

probe_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

probe_wait_healthy() {
    local url="$1" i
    shift
    for i in $(seq 300); do
        "$FMUCAL" health "$url" --timeout 2 "$@" >/dev/null 2>&1 && return 0
        sleep 0.2
    done
    echo "bench/probe.sh: $url did not become healthy" >&2
    return 1
}

started="$(date +%s)"
for cases in bench/probe.d/*.sh; do
    [ -e "$cases" ] || continue
    echo "# $cases"
    # shellcheck source=/dev/null
    source "$cases"
done

# Nothing left behind: every server stopped, no process of this run alive, the repository
# unchanged.
for name in "${!servers[@]}"; do
    probe_stop "$name"
done
sleep 0.5
left="$(probe_processes)"
if [ -n "$left" ]; then
    report "no process left running" FAIL "$(for p in $left; do tr '\0' ' ' <"/proc/$p/cmdline"; echo; done | head -3)"
    for p in $left; do kill -KILL "$p" 2>/dev/null; done
else
    report "no process left running" PASS "none of this run's processes is alive"
fi
repo_after="$(repo_state)"
if [ "$repo_before" = "$repo_after" ]; then
    report "no file written outside the scratch folder" PASS "the repository is unchanged"
else
    report "no file written outside the scratch folder" FAIL "$(diff <(echo "$repo_before") <(echo "$repo_after") | head -3 | tr '\n' ' ')"
fi
echo "probe: $(($(date +%s) - started)) s"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
