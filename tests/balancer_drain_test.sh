#!/usr/bin/env bash
# A replica's graceful stop behind the deployment's balancer costs no client
# a call. HAProxy runs deploy/haproxy/haproxy.cfg with its backend and
# health check unchanged (only the listener and the two replicas' addresses
# are made local); the two replicas share sessions through Redis. While
# meshgauge-load's clients iterate through the balancer, each replica in
# turn gets SIGTERM (health NOT_SERVING for its 4 s drain notice, then
# drain and stop) and is started again.
# Pass, per stop: the balancer marks the replica DOWN within 3.5 s, while
# it still serves (so no call can reach it as gRPC shuts down, where it
# would end CANCELLED), and UP again after its restart; at the end the load
# client saw 0 errors, 0 mismatches, 0 lost sessions. Then the balancer
# itself is reloaded (SIGUSR2 to its master process, as
# `deploy/stack.sh reload-balancer` does) three times under a load whose
# clients do not retry: 0 errors.
#   balancer_drain_test.sh SERVER LOAD CFG [CYCLES]
set -euo pipefail
server=$1 load=$2 cfg=$3 cycles=${4:-2}
for tool in haproxy redis-server; do
  command -v "$tool" >/dev/null || { echo "needs $tool (scripts/install_deps.sh)"; exit 1; }
done
tmp=$(mktemp -d)
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$tmp"; }
trap cleanup EXIT
source "$(dirname "$0")/../scripts/lib.sh"
fail() {
  echo "--- load client"; cat "$tmp/load.txt" 2>/dev/null || true
  echo "--- balancer"; cat "$tmp/haproxy.log"
  echo "FAIL: $*"
  exit 1
}
# Waits up to $2 tenths of a second for the balancer's log to hold more
# than $3 lines matching $1.
await_log() { await_lines "$tmp/haproxy.log" "$1" "$3" "$2"; }

start_redis "$tmp"

# Each replica binds port 0 first and keeps the port it got on restarts
# (the balancer's configuration names it).
ports=(0 0)
replica_pid=()
start_replica() {  # INDEX
  rm -f "$tmp/port$1"
  "$server" --address "127.0.0.1:${ports[$1]}" --metrics_address= \
    --port_file "$tmp/port$1" \
    --session_store "redis://127.0.0.1:$redis_port" --drain_notice_seconds=4 \
    --shutdown_grace_seconds=20 2>>"$tmp/replica$1.log" &
  replica_pid[$1]=$!
  pids+=($!)
  ports[$1]=$(await_port_file "$tmp/port$1")
}
start_replica 0
start_replica 1

hp=$(free_port) health_port=$(free_port)
sed -e "s|^ *bind :50051 .*|  bind 127.0.0.1:$hp proto h2|" \
    -e "s|^ *bind 127.0.0.1:8404|  bind 127.0.0.1:$health_port|" \
    -e "s|^ *server-template .*|  server r0 127.0.0.1:${ports[0]}\n  server r1 127.0.0.1:${ports[1]}|" \
    "$cfg" >"$tmp/haproxy.cfg"
haproxy -W -db -f "$tmp/haproxy.cfg" 2>"$tmp/haproxy.log" &
haproxy_pid=$!
pids+=($!)
await_tcp "$hp"
# The balancer's own health: plain HTTP 200 on its health port.
curl -sf "http://127.0.0.1:$health_port/healthz" >/dev/null ||
  fail "the balancer's health frontend did not answer 200"

# Waits for 12 more iterations of the load (3 progress lines); $1 names the
# moment for the failure message.
await_progress() {
  local before
  before=$(grep -c '^iterations:' "$tmp/load.txt" || true)
  await_lines "$tmp/load.txt" '^iterations:' $((before + 2)) 300 ||
    fail "the load made no progress $1"
  kill -0 "$load_pid" 2>/dev/null || fail "the load ended $1"
}
# Waits for the load to end; fails with $1 unless it saw no error.
finish_load() {
  local rc=0
  wait "$load_pid" || rc=$?
  sed -n '/^errors:/,$p' "$tmp/load.txt"
  [ "$rc" -eq 0 ] && grep -q "^errors: 0" "$tmp/load.txt" || fail "$1"
}

"$load" --target "127.0.0.1:$hp" --clients 4 --iterations $((cycles * 150)) \
  --frequency 4 --session_prefix drain --time_limit_seconds 120 \
  --progress_every 4 >"$tmp/load.txt" 2>&1 &
load_pid=$!
for c in $(seq 1 "$cycles"); do
  r=$((c % 2))
  await_progress "before stop $c"  # through both replicas.
  downs=$(grep -c "meshgauge/r$r is DOWN" "$tmp/haproxy.log" || true)
  ups=$(grep -c "meshgauge/r$r is UP" "$tmp/haproxy.log" || true)
  t0=$(date +%s.%N)
  kill -TERM "${replica_pid[$r]}"
  await_log "meshgauge/r$r is DOWN" 35 "$downs" ||
    fail "3.5 s after SIGTERM the balancer still routes to replica $r"
  echo "stop $c: replica $r out of the balancer $(awk -v t0="$t0" -v t1="$(date +%s.%N)" 'BEGIN { printf "%.2f", t1 - t0 }') s after SIGTERM"
  kill -0 "${replica_pid[$r]}" 2>/dev/null ||
    fail "replica $r stopped before the balancer marked it DOWN"
  wait "${replica_pid[$r]}" || true
  start_replica "$r"
  await_log "meshgauge/r$r is UP" 100 "$ups" ||
    fail "the balancer did not take replica $r back within 10 s"
done
finish_load "a graceful stop cost the clients calls"
echo "PASS: $cycles graceful stops, each replica left the balancer before it stopped, no client saw an error"

"$load" --target "127.0.0.1:$hp" --clients 4 --iterations 60 --retry=false \
  --frequency 4 --session_prefix reload --time_limit_seconds 120 \
  --progress_every 4 >"$tmp/load.txt" 2>&1 &
load_pid=$!
for c in 1 2 3; do
  await_progress "before reload $c"
  kill -USR2 "$haproxy_pid"
  echo "reload $c of the balancer"
done
await_progress "after the reloads"
finish_load "a reload of the balancer cost a client without retries a call"
echo "PASS: 3 reloads of the balancer, no client (without retries) saw an error"
