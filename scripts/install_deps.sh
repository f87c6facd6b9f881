#!/usr/bin/env bash
# Installs the Debian 12 packages meshgauge needs, and any packages given as
# arguments (scripts/bench_cgal.sh: libcgal-dev), idempotently: apt-get runs
# only when a package is missing. Uses sudo when not root.
#   install_deps.sh [--build | --test] [--check] [PACKAGE...]
# --build: only what the build needs (and the report page's three.js);
# --test: only what the tests add (scripts/test.sh installs these while the
# build runs); --check: install nothing, exit 1 when a package is missing.
set -euo pipefail

BUILD_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libembree-dev libtbb-dev libopenmesh-dev libabsl-dev nlohmann-json3-dev
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  prometheus-cpp-dev zlib1g-dev libgtest-dev libgmock-dev libssl-dev
  libcli11-dev libhiredis-dev libpng-dev libeigen3-dev
  # The Python package's stubs (client/python/gen_stubs.py) and
  # scripts/fetch_npm_lock.py.
  python3
)
TEST_PACKAGES=(
  python3-grpcio python3-protobuf python3-numpy python3-scipy
  python3-venv python3-pip python3-wheel python3-setuptools mypy
  # The sanitizer build, fuzzing and the thread-safety check.
  clang-14 libfuzzer-14-dev
  openssl redis-server haproxy chromium
  # curl: the balancer test's health check; bc: scripts/bench_clients.sh.
  curl bc
)
PACKAGES=("${BUILD_PACKAGES[@]}" "${TEST_PACKAGES[@]}")
web=1  # the report page's three.js comes with the build's packages.
check=0
while [[ "${1:-}" == --* ]]; do
  case "$1" in
    --build) PACKAGES=("${BUILD_PACKAGES[@]}") ;;
    --test) PACKAGES=("${TEST_PACKAGES[@]}"); web=0 ;;
    --check) check=1 ;;
    *) echo "install_deps: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
PACKAGES+=("$@")

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "$check" -eq 1 ]; then
  [ ${#missing[@]} -eq 0 ] || { echo "install_deps: missing ${missing[*]}"; exit 1; }
  exit 0
fi
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
else
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "install_deps: installing ${missing[*]}"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
if [ "$web" -eq 1 ]; then
  # The report page's three.js (from the npm registry, pinned in
  # web/package-lock.json), bundled into web/vendor/.
  "$(dirname "$0")/install_web_deps.sh"
fi
