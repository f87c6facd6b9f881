#!/usr/bin/env bash
# The Python client's cost per optimiser iteration against the C++ client's
# (update every vertex, SDF, VJP), both against one meshgauge-server on
# loopback, on MESH (default igea). Not part of the test run.
#   scripts/bench_clients.sh [MESH] [ITERATIONS]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_setup.sh
trap 'kill "$server" 2>/dev/null || true; rm -rf "$tmp"' EXIT
build/server/meshgauge-server --address 127.0.0.1:0 --metrics_address= \
  --port_file "$tmp/port" 2>"$tmp/server.log" &
server=$!
source scripts/lib.sh
target="127.0.0.1:$(await_port_file "$tmp/port")"
cpp=$(build/bench/meshgauge_client_bench --iterations "$N" --dump "$tmp/mesh.obj" \
      "$target" "$MESH" | tee /dev/stderr | grep -o '[0-9.]* s' | cut -d' ' -f1)
py=$(PYTHONPATH=build/python /usr/bin/python3 bench/python_client_bench.py \
      "$target" "$tmp/mesh.obj" "$N" | tee /dev/stderr | grep -o '[0-9.]* s' | cut -d' ' -f1)
echo "Python / C++ per iteration: $(echo "$py / $cpp" | bc -l | cut -c1-5) (goal <= 1.15)"
