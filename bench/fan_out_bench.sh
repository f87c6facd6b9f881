#!/usr/bin/env bash
# One pass of a big mesh through HAProxy (deploy/haproxy/haproxy.cfg, TLS
# off) in front of two meshgauge-server replicas sharing Redis, each pinned
# to one CPU (taskset -c 0, -c 1; --compute_threads 1): `meshgauge remote
# sdf MESH --fan-out 1` against `--fan-out 2`, wall times and their ratio
# (issue 54; docs/deployment.md, "Fan-out"). Heavy (minutes), not in CI.
# Hold the build lock while it runs:
#   flock /tmp/meshgauge-build.lock bench/fan_out_bench.sh \
#     build/server/meshgauge-server build/client/meshgauge MESH [RAYS] [ROUNDS] [K...]
# MESH: e.g. `meshgauge shape torus --size 0.0115 --out torus.obj` (about
# 550k vertices). Each run uses its own --kappa (1, 1.0001, ...), so that no
# replica's cached pass serves it (the filter's width costs no rays).
set -euo pipefail
server=$(realpath "$1") cli=$(realpath "$2") mesh=$(realpath "$3")
rays=${4:-100} rounds=${5:-2}
shift $(( $# < 5 ? $# : 5 ))
fan_outs=("${@:-1 2}")
[ $# -gt 0 ] || fan_outs=(1 2)
cd "$(dirname "$0")/.."
for tool in haproxy redis-server taskset; do
  command -v "$tool" >/dev/null || { echo "needs $tool"; exit 1; }
done
tmp=$(mktemp -d)
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$tmp"; }
trap cleanup EXIT
source scripts/lib.sh
start_redis "$tmp"
ports=()
for r in 0 1; do
  taskset -c "$r" "$server" --address 127.0.0.1:0 --metrics_address= \
    --port_file "$tmp/port$r" --compute_threads 1 \
    --session_store "redis://127.0.0.1:$redis_port" 2>>"$tmp/replica$r.log" &
  pids+=($!)
  ports[$r]=$(await_port_file "$tmp/port$r")
done
hp=$(free_port)
sed -e "s|^ *bind :50051 .*|  bind 127.0.0.1:$hp proto h2|" \
    -e "s|^ *bind 127.0.0.1:8404|  bind 127.0.0.1:$(free_port)|" \
    -e "s|^ *server-template .*|  server r0 127.0.0.1:${ports[0]}\n  server r1 127.0.0.1:${ports[1]}|" \
    -e "s|^ *log stderr format raw local0 warning|  log stderr format raw local0 info|" \
    deploy/haproxy/haproxy.cfg >"$tmp/haproxy.cfg"
haproxy -W -db -f "$tmp/haproxy.cfg" 2>>"$tmp/haproxy.log" &
pids+=($!)
await_tcp "$hp"
remote() { "$cli" remote "$@" --server "127.0.0.1:$hp"; }
seconds() {  # COMMAND...: its wall time
  local t0
  t0=$(date +%s.%N)
  "$@" >/dev/null
  awk -v t0="$t0" -v t1="$(date +%s.%N)" 'BEGIN { printf "%.2f", t1 - t0 }'
}
vertices=$(grep -c '^v ' "$mesh")
echo "mesh $mesh: $vertices vertices, $rays rays, replicas pinned to one CPU each"
echo "upload (one replica writes the session to Redis): $(seconds remote upload "$mesh" --session-id big) s"
# The CLI reads and checks MESH before every verb: its share of each time.
read_seconds=$(seconds "$cli" sdf "$mesh" --rays 1 --method normal)
echo "reading MESH in the CLI: $read_seconds s (a 1-ray local pass included)"
run=0
for round in $(seq 1 "$rounds"); do
  for k in "${fan_outs[@]}"; do
    kappa=$(awk -v r="$run" 'BEGIN { printf "%.4f", 1 + r / 10000 }')
    run=$((run + 1))
    t=$(seconds remote sdf "$mesh" --session-id big --rays "$rays" --kappa "$kappa" --fan-out "$k")
    # Where its ComputeSdf calls went (the balancer's request lines).
    n0=$(grep -cE "meshgauge(_parts)?/r0 .*ComputeSdf" "$tmp/haproxy.log" || true)
    n1=$(grep -cE "meshgauge(_parts)?/r1 .*ComputeSdf" "$tmp/haproxy.log" || true)
    echo "round $round fan-out $k: $t s (ComputeSdf calls so far: replica 0 $n0, replica 1 $n1)"
    [ "$k" = 1 ] && t_one=$t
    [ "$k" = 1 ] || awk -v a="$t_one" -v b="$t" -v k="$k" -v r="$read_seconds" \
      'BEGIN { printf "  ratio fan-out 1 / fan-out %d: %.2f (less the CLI'"'"'s reading of MESH: %.2f)\n", k, a / b, (a - r) / (b - r) }'
  done
done
grep -h "loaded\|restored" "$tmp"/replica*.log | head -4 || true
