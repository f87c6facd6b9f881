#!/usr/bin/env bash
# Makes a Docker engine available: installs Debian's docker.io, debootstrap
# and docker-compose if missing, and starts dockerd if none answers.
# Exit status 0 when `docker info` works afterwards.
set -euo pipefail
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
need=()
command -v docker >/dev/null || need+=(docker.io)
command -v debootstrap >/dev/null || need+=(debootstrap)
command -v docker-compose >/dev/null || need+=(docker-compose)
if [ ${#need[@]} -gt 0 ]; then
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q "${need[@]}"
fi
if ! docker info >/dev/null 2>&1; then
  echo "ensure-docker: starting dockerd"
  $SUDO sh -c 'nohup dockerd >/tmp/dockerd.log 2>&1 &'
  for _ in $(seq 1 60); do
    docker info >/dev/null 2>&1 && break
    sleep 1
  done
fi
docker info >/dev/null 2>&1 || { echo "ensure-docker: no Docker engine (see /tmp/dockerd.log)"; exit 1; }
echo "ensure-docker: engine $(docker version --format '{{.Server.Version}}')"
