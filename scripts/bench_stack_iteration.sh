#!/usr/bin/env bash
# One optimiser iteration (move every vertex, SDF, VJP) on MESH (default
# igea) through an HAProxy balancer to a replica whose sessions live in
# Redis, against the same iteration in-process (alternating in one process,
# so both see the same machine; best of N each; goal <= 1.15), and the cost
# of a cache miss on a second replica (record loaded from Redis + BVH
# build). Everything on this host, plaintext loopback. Not part of the test
# run.
#   scripts/bench_stack_iteration.sh [MESH] [ITERATIONS]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_setup.sh
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true; rm -rf "$tmp"' EXIT
source scripts/lib.sh
start_redis "$tmp" yes
ports=()
for r in 1 2; do
  build/server/meshgauge-server --address 127.0.0.1:0 --metrics_address= \
    --session_store "redis://127.0.0.1:$redis_port" --port_file "$tmp/port$r" \
    2>"$tmp/server$r.log" &
  pids+=($!)
  ports+=("$(await_port_file "$tmp/port$r")")
done
hp=$(free_port)
cat >"$tmp/haproxy.cfg" <<CFG
defaults
  mode http
  timeout connect 2s
  timeout client 10m
  timeout server 10m
frontend grpc
  bind 127.0.0.1:$hp proto h2
  default_backend replicas
backend replicas
  balance hdr(x-meshgauge-session)
  hash-type consistent
  server r1 127.0.0.1:${ports[0]} proto h2
CFG
haproxy -db -f "$tmp/haproxy.cfg" &
pids+=($!)
await_tcp "$hp"
build/bench/meshgauge_client_bench --iterations "$N" --in_process \
  --miss_target "127.0.0.1:${ports[1]}" "127.0.0.1:$hp" "$MESH"
