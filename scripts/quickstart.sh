#!/usr/bin/env bash
# Quick start: install dependencies, build, and run the main job: the
# meshgauge gRPC server on localhost (gRPC 127.0.0.1:50051, Prometheus
# metrics http://127.0.0.1:9464/metrics) until Ctrl-C / SIGTERM.
# Extra arguments go to meshgauge-server (e.g. --address 127.0.0.1:6000).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh
echo "meshgauge: try, from another terminal:"
echo "  build/client/meshgauge remote sdf data/meshes/spot_triangulated.obj"
echo "  PYTHONPATH=build/python /usr/bin/python3 client/python/examples/thicken_dumbbell.py"
exec build/server/meshgauge-server --address 127.0.0.1:50051 \
  --metrics_address 127.0.0.1:9464 "$@"
