#!/usr/bin/env bash
# Runs the whole test suite: installs dependencies, builds, runs CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
cd build
# --no-tests=error: a configuration that lost its tests must not pass.
ctest --output-on-failure --no-tests=error -j"$(nproc)"
