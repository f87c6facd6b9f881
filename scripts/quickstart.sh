#!/usr/bin/env bash
# Quick start: install dependencies, build, and run the main job (the CLI on
# a generated sphere and, when ../shared is present, on a real scan).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
mkdir -p build/examples
build/client/meshgauge shape sphere --radius 0.5 --size 0.02 --out build/examples/sphere.obj
echo "== meshgauge sdf build/examples/sphere.obj (diameter 1)"
build/client/meshgauge sdf build/examples/sphere.obj --ply build/examples/sphere_sdf.ply
if [ -f ../shared/meshes/spot_triangulated.obj ]; then
  echo "== meshgauge sdf ../shared/meshes/spot_triangulated.obj"
  build/client/meshgauge sdf ../shared/meshes/spot_triangulated.obj --csv build/examples/spot.csv
fi
