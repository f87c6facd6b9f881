#!/usr/bin/env bash
# Runs the whole test suite: installs dependencies, builds, runs CTest.
# The packages only the tests need are installed while the build runs (on
# a fresh machine, apt-get and the build take minutes each).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh --build
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# A password sudo asks for is asked here, not by the background apt-get.
if [ "$(id -u)" -ne 0 ] && ! scripts/install_deps.sh --test --check >/dev/null 2>&1; then
  sudo -v
fi
scripts/install_deps.sh --test >"$log" 2>&1 &
test_deps=$!
build_rc=0
scripts/build.sh || build_rc=$?
deps_rc=0
wait "$test_deps" || deps_rc=$?
tail -n 1 "$log"
if [ "$deps_rc" -ne 0 ]; then cat "$log"; exit "$deps_rc"; fi
[ "$build_rc" -eq 0 ] || exit "$build_rc"
cd build
# --no-tests=error: a configuration that lost its tests must not pass.
../scripts/ctest_failures.sh --output-on-failure --no-tests=error -j"$(nproc)"
