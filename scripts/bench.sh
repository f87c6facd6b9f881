#!/usr/bin/env bash
# Benchmarks (not part of the test run): meshgauge's ray pass vs a raw Embree
# rtcIntersect1 pass over the same rays (in the file's vertex order), on the
# shared meshes and on igea with its vertices permuted.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
build/bench/meshgauge_bench "$@" ../shared/meshes/igea-triangles.ply ../shared/meshes/horse.ply \
  ../shared/meshes/stanford-bunny.obj ../shared/meshes/rocker-arm.obj
# igea again, and with its vertices randomly permuted (fixed seed): the ray
# pass visits vertices in Morton order, so a scrambled order costs little.
build/bench/meshgauge_bench "$@" --permute_seed 7 ../shared/meshes/igea-triangles.ply
