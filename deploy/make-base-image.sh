#!/usr/bin/env bash
# Provides the base image the Dockerfiles build FROM (build argument BASE):
# debian:bookworm when it can be pulled, otherwise an equivalent made here
# with `debootstrap --variant=minbase bookworm` from Debian's archive and
# `docker import` (about 40 s). Tags it meshgauge/bookworm-base:latest.
# Idempotent: does nothing when the tag exists.
set -euo pipefail
TAG=meshgauge/bookworm-base:latest
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
if docker image inspect "$TAG" >/dev/null 2>&1; then
  echo "make-base-image: $TAG exists"
  exit 0
fi
if timeout 60 docker pull debian:bookworm >/dev/null 2>&1; then
  docker tag debian:bookworm "$TAG"
  echo "make-base-image: $TAG = debian:bookworm (pulled)"
  exit 0
fi
echo "make-base-image: no registry; debootstrap from $MIRROR"
ROOT=$(mktemp -d)
trap 'rm -rf "$ROOT"' EXIT
debootstrap --variant=minbase bookworm "$ROOT" "$MIRROR" >/tmp/debootstrap.log 2>&1 || {
  tail -20 /tmp/debootstrap.log; exit 1; }
cat >"$ROOT/etc/apt/sources.list" <<SOURCES
deb $MIRROR bookworm main
deb $MIRROR bookworm-updates main
deb ${MIRROR%/debian}/debian-security bookworm-security main
SOURCES
rm -rf "$ROOT"/var/cache/apt/archives/*.deb "$ROOT"/var/lib/apt/lists/*
tar -C "$ROOT" -c . | docker import - "$TAG" >/dev/null
echo "make-base-image: $TAG imported ($(docker image inspect -f '{{.Size}}' "$TAG") bytes)"
