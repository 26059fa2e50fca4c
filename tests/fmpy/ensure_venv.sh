#!/usr/bin/env bash
# Creates (once) the Python venv that fmucal's cross-checks and benchmarks use, with FMPy and
# SciPy from PyPI, and prints the path of its python. Safe to run concurrently (flock).
# Location: $FMUCAL_PYENV, else <repo>/target/pyenv.
# If the packages cannot be installed (no route to the package registry, say), it prints one
# line saying so, with the path of pip's full log, and exits 1.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${FMUCAL_PYENV:-$repo/target/pyenv}"
req="$here/requirements.txt"
stamp="$venv/.fmucal-ready-$(sha256sum "$req" | cut -c1-16)"
mkdir -p "$(dirname "$venv")"
exec 9>"$venv.lock"
flock 9
if [ ! -f "$stamp" ]; then
  rm -rf "$venv"
  log="$venv.pip.log"
  if ! { python3 -m venv "$venv" && "$venv/bin/python" -m pip install --disable-pip-version-check -r "$req"; } >"$log" 2>&1; then
    echo "fmucal: cannot install the Python reference tools ($(tr '\n' ' ' <"$req" | grep -o '[a-z]*==[0-9.]*' | head -1) and others) from PyPI: is the package registry reachable? pip's log: $log" >&2
    rm -rf "$venv"
    exit 1
  fi
  touch "$stamp"
fi
echo "$venv/bin/python"
