#!/usr/bin/env bash
# Builds the Docker image fmucal:latest from the runtime stage of deploy/Dockerfile, as it is
# there, on the local base image (tests/containers/base_image.sh) in place of
# debian:bookworm-slim and with the binary built outside (BIN, default target/release/fmucal)
# in place of the build stage's. Prints the image name.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
bin="${BIN:-$repo/target/release/fmucal}"
image="${IMAGE:-fmucal:latest}"
[ -x "$bin" ] || { echo "containers: no fmucal binary at $bin (cargo build --release)" >&2; exit 1; }
base="$(bash "$here/base_image.sh")"
context="$(mktemp -d)"
trap 'rm -rf "$context"' EXIT
cp "$bin" "$context/fmucal"
# The FMU runtime of `fmucal export`, which cargo leaves in deps/ beside the binary.
lib="$(dirname "$bin")/deps/libfmucal_fmu.so"
[ -f "$lib" ] || lib="$(dirname "$bin")/libfmucal_fmu.so"
[ -f "$lib" ] || { echo "containers: no libfmucal_fmu.so beside $bin (cargo build --release)" >&2; exit 1; }
cp "$lib" "$context/libfmucal_fmu.so"
# The last stage of the published Dockerfile, with its base and its binary's source replaced.
awk '/^FROM /{ stage = "" } { stage = stage $0 "\n" } END { printf "%s", stage }' "$repo/deploy/Dockerfile" \
  | sed -e "s|^FROM debian:bookworm-slim.*|FROM $base|" \
        -e "s|^COPY --from=build /src/target/release/fmucal |COPY fmucal |" \
        -e "s|^COPY --from=build /src/target/release/deps/libfmucal_fmu.so |COPY libfmucal_fmu.so |" >"$context/Dockerfile"
grep -q "^FROM $base" "$context/Dockerfile" && grep -q "^COPY fmucal " "$context/Dockerfile" \
  || { echo "containers: deploy/Dockerfile's runtime stage no longer has the lines this script replaces" >&2; exit 1; }
DOCKER_BUILDKIT=0 docker build -q -t "$image" "$context" >/dev/null
echo "$image"
