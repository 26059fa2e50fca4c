#!/usr/bin/env bash
# Makes (once) the local Docker image fmucal-base:bookworm: a Debian bookworm minbase root
# filesystem made with debootstrap from this machine's own Debian mirror, imported with
# `docker import`. It stands in for debian:bookworm-slim where no image registry can be reached.
# Prints the image name. Installs debootstrap with apt-get if it is missing (needs root).
set -euo pipefail
image="fmucal-base:bookworm"
if docker image inspect "$image" >/dev/null 2>&1; then
  echo "$image"
  exit 0
fi
if ! command -v debootstrap >/dev/null; then
  echo "containers: installing debootstrap (apt-get)" >&2
  apt-get update -qq >&2 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >&2
fi
# This machine's Debian mirror: the first URI of its apt sources (deb822 or one-line format).
mirror="$(awk '/^URIs:/ { print $2; exit }' /etc/apt/sources.list.d/*.sources 2>/dev/null || true)"
if [ -z "$mirror" ]; then
  mirror="$(awk '$1 == "deb" { print $2; exit }' /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null || true)"
fi
[ -n "$mirror" ] || { echo "containers: no Debian mirror in this machine's apt sources" >&2; exit 1; }
rootfs="$(mktemp -d)"
trap 'rm -rf "$rootfs"' EXIT
echo "containers: debootstrap bookworm (minbase) into $rootfs" >&2
debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >"$rootfs.log" 2>&1 \
  || { echo "containers: debootstrap failed, see $rootfs.log" >&2; exit 1; }
rm -f "$rootfs.log"
# What debian:bookworm-slim leaves out as well.
rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/* "$rootfs"/usr/share/doc/* \
  "$rootfs"/usr/share/man/* "$rootfs"/usr/share/info/*
tar -C "$rootfs" -c . | docker import - "$image" >/dev/null
echo "$image"
