#!/usr/bin/env bash
# Benchmarks (not part of the test run): meshgauge's ray pass vs a raw Embree
# rtcIntersect1 pass over the same rays, on the shared meshes.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
build/bench/meshgauge_bench "$@" ../shared/meshes/igea-triangles.ply ../shared/meshes/horse.ply \
  ../shared/meshes/stanford-bunny.obj ../shared/meshes/rocker-arm.obj
