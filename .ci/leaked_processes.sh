#!/usr/bin/env bash
# Lists the processes running this checkout's fmucal binaries (target/*/fmucal and the test
# binaries under target/*/deps), one pid a line.
#   leaked_processes.sh snapshot FILE   writes the pids running now to FILE
#   leaked_processes.sh check FILE      fails, naming each, if one not in FILE still runs
# Only processes whose executable lies in this checkout's target folder are considered, so
# another checkout's or another user's fmucal is never counted, and nothing is killed.
set -euo pipefail
cd "$(dirname "$0")/.."
target="$(pwd -P)/target/"
ours() {
    local exe pid
    for d in /proc/[0-9]*; do
        pid="${d#/proc/}"
        exe="$(readlink "$d/exe" 2>/dev/null || true)"
        exe="${exe% (deleted)}"
        case "$exe" in
            "$target"*/fmucal | "$target"*/deps/*) echo "$pid" ;;
        esac
    done
}
case "${1:-}" in
    snapshot) ours | sort >"$2" ;;
    check)
        # This script's own shell is not an fmucal process; a process that ends while the
        # list is made just drops out of it.
        leaked="$(ours | sort | comm -23 - "$2")"
        if [ -n "$leaked" ]; then
            echo "processes started by the test suite are still running:" >&2
            for pid in $leaked; do
                echo "  $pid: $(tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null || echo '(gone)')" >&2
            done
            exit 1
        fi
        echo "no process started by the test suite is left running"
        ;;
    *) echo "usage: $0 snapshot FILE | check FILE" >&2; exit 2 ;;
esac
