#!/usr/bin/env bash
# meshgauge vs CGAL's sdf_values vs raw Embree (docs/benchmarks.md): installs
# Debian's libcgal-dev (header-only; not needed by anything else), builds
# meshgauge_cgal_bench and runs it on the test meshes (data/meshes) and the
# generated ones (CGAL single-threaded: about 5 minutes on 2 cores). Extra
# arguments go to meshgauge_cgal_bench.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh libcgal-dev
scripts/build.sh
M=data/meshes
build/bench/meshgauge_cgal_bench "$@" $M/decimated-knight.off \
  $M/spot_triangulated.obj $M/fandisk.obj $M/rocker-arm.obj $M/horse.ply \
  $M/igea-triangles.ply
