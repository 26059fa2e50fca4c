#!/usr/bin/env bash
# Creates (once) the Python venv that fmucal's cross-checks and benchmarks use, with FMPy and
# SciPy from PyPI, and prints the path of its python. Safe to run concurrently (flock).
# Location: $FMUCAL_PYENV, else <repo>/target/pyenv.
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
  python3 -m venv "$venv" >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req" >&2
  touch "$stamp"
fi
echo "$venv/bin/python"
