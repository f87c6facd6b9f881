#!/usr/bin/env bash
# Installs the Debian 12 packages meshgauge needs, and any packages given as
# arguments (scripts/bench_cgal.sh: libcgal-dev), idempotently: apt-get runs
# only when a package is missing. Uses sudo when not root.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libembree-dev libtbb-dev libopenmesh-dev libabsl-dev nlohmann-json3-dev
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  prometheus-cpp-dev zlib1g-dev
  libgtest-dev libgmock-dev
  python3 python3-grpcio python3-protobuf python3-numpy python3-scipy
  clang-14 libfuzzer-14-dev openssl libssl-dev
  python3-venv python3-pip python3-wheel python3-setuptools mypy libcli11-dev
  redis-server libhiredis-dev haproxy libpng-dev chromium
  # curl: the balancer test's health check; bc: scripts/bench_clients.sh.
  curl bc
  libeigen3-dev
  "$@"
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
else
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "install_deps: installing ${missing[*]}"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
# The report page's three.js (from the npm registry, pinned in
# web/package-lock.json), bundled into web/vendor/.
"$(dirname "$0")/install_web_deps.sh"
