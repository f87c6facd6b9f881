#!/usr/bin/env bash
# Benchmarks (not part of the test run), in one run on the same rays: every
# raw Embree configuration (bench/raw_embree_pass.h), meshgauge's ray pass and
# the whole `meshgauge sdf` run (wall time, stages, memory and peak RSS) with
# their ratios to the fastest raw pass, on the test meshes (data/meshes), on
# igea with its vertices permuted and on a generated mesh of a million
# vertices (25 rays);
# Embree's watertight ray test against its fast one on every test mesh;
# then incremental passes after patch updates (meshgauge_incremental_bench),
# the VJP's scatter alone (meshgauge_scatter_bench) and the CLI's start-up
# (bench/cli_startup_bench.sh).
# About 10 minutes on 2 cores. Extra arguments go to every meshgauge_bench.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
CLI="$PWD/build/client/meshgauge"
# igea in file order and with its vertices randomly permuted (fixed seed):
# the ray pass visits vertices in Morton order, so a scrambled order costs
# little.
build/bench/meshgauge_bench --cli "$CLI" --permute_seed 7 "$@" \
  data/meshes/igea-triangles.ply
build/bench/meshgauge_bench --cli "$CLI" "$@" data/meshes/horse.ply \
  data/meshes/stanford-bunny.obj data/meshes/rocker-arm.obj
build/bench/meshgauge_bench --cli "$CLI" --rays 25 --repeat 1 \
  --generated_vertices 1000000 "$@"
# Embree's watertight ray test (meshgauge's) against its fast one on every
# test mesh: both rates, hit fractions, vertices whose value differs.
build/bench/meshgauge_bench --ray_tests_only "$@" data/meshes/*.ply \
  data/meshes/*.obj data/meshes/*.off data/meshes/*.STL
# Incremental passes (issue 25's goals): 1 % and 10 % patches and every
# vertex moved, against a full pass.
build/bench/meshgauge_incremental_bench data/meshes/igea-triangles.ply \
  data/meshes/rocker-arm.obj
# The VJP's scatter alone: three ExactSums::Add a term against
# AddScaledTerms in AVX and in SSE2 (the same sums).
build/bench/meshgauge_scatter_bench data/meshes/igea-triangles.ply \
  data/meshes/stanford-bunny.obj data/meshes/rocker-arm.obj
# Start-up of the CLI's programs: the local verbs' `meshgauge` loads no
# gRPC; `meshgauge-remote` does.
bench/cli_startup_bench.sh build
