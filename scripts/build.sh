#!/usr/bin/env bash
# Configures and builds meshgauge (Release, -O2) into ./build (or DIR).
# A new build folder is configured for Ninja when it is installed (Debian's
# ninja-build, from scripts/install_deps.sh); an existing one keeps the
# generator it was configured with.
#   scripts/build.sh [DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
dir="${1:-build}"
generator=()
if [ ! -f "$dir/CMakeCache.txt" ] && command -v ninja >/dev/null; then
  generator=(-G Ninja)
fi
cmake -S . -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$dir" -j"$(nproc)"
