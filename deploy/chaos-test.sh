#!/usr/bin/env bash
# Chaos test of the stack (deploy/stack.sh): while the project's load client
# (meshgauge-load: 6 clients, UpdatePositions -> ComputeSdf -> ComputeVjp or
# ComputePenalty, every reply compared bit for bit with a single-client
# reference at the same positions, every session checked at the end) runs
# through the balancer, one fault per phase. The clients start before the
# fault and go on until it is over and they have made 30 more iterations (in
# all, about 5 per client); then they are told to stop (meshgauge-load
# --until_signal, SIGTERM), so the load outlasts any fault:
#   kill     a replica's server process is SIGKILLed (a crash; its restart
#            policy brings it back)
#   fanout   the same crash under one big client instead (16k vertices,
#            every pass, VJP and penalty split into 2 parts sent at once,
#            one per replica): the killed replica's part is asked again
#            and reaches the other replica
#   restart  the replicas in turn are restarted (graceful stop, start;
#            CHAOS_RESTARTS times, default 2: each once)
#   scale    a third replica is added (deploy/stack.sh scale 3)
#   pause    a replica's server process is stopped (SIGSTOP) for
#            CHAOS_PAUSE_SECONDS (default 20), then continued: a hung
#            replica, which still accepts connections. No call may take
#            longer than CHAOS_MAX_LATENCY (default 10 s): the balancer
#            ends the calls of a replica that stops answering its health
#            checks (haproxy.cfg), and they are retried elsewhere.
#   stop     a replica is stopped gracefully (drain) and stays down
#   redis    Redis is restarted (its AOF keeps the sessions)
#   attack   deploy/attacker.py, against the measured clients' sessions:
#            updates of every position x 1e14 (refused, and nothing may
#            change), ComputeSdf streams left unread for 15 s, two anonymous
#            100 MiB UpdatePositions (UNAUTHENTICATED, unread); no call of
#            the measured clients over CHAOS_MAX_LATENCY
# A plain gRPC client written from the proto (deploy/plain_client.py, only
# gRPC's UNAVAILABLE retry policy) runs through all phases.
# Pass: every phase with 0 client-visible errors, 0 mismatches, 0 sessions
# lost, and in the pause phase no call over the bound; the plain client
# with 0 NOT_FOUND. Per phase it reports calls,
# retried attempts (the replicas' meshgauge_rpc_retried_attempts_total in
# Prometheus) and p50/p99 latency per RPC. Brings the stack down at the end
# with `down --prune` and checks that the build stage is gone.
# Its stack is its own (project meshgauge-chaos, ports 50251, 9290, 9293,
# secrets in /tmp/meshgauge-chaos-test, run directory
# deploy/.run/meshgauge-chaos): an operator's
# stack (deploy/stack.sh's defaults) beside it is not touched.
set -euo pipefail
cd "$(dirname "$0")"
source ../scripts/lib.sh
CHAOS_HOME=${CHAOS_HOME:-/tmp/meshgauge-chaos-test}
export MESHGAUGE_PROJECT=${CHAOS_PROJECT:-meshgauge-chaos}
export MESHGAUGE_GRPC_PORT=${CHAOS_GRPC_PORT:-50251}
export MESHGAUGE_PROMETHEUS_PORT=${CHAOS_PROMETHEUS_PORT:-9290}
export MESHGAUGE_ALERTMANAGER_PORT=${CHAOS_ALERTMANAGER_PORT:-9293}
export MESHGAUGE_SECRETS_DIR=$CHAOS_HOME/secrets MESHGAUGE_RUN_DIR=$PWD/.run/$MESHGAUGE_PROJECT
# No receiver: this test does not look at notifications.
export MESHGAUGE_ALERT_WEBHOOK_URL=http://127.0.0.1:9/none
source ./stack-lib.sh
MESHGAUGE_VERSION=$(meshgauge_version)
export MESHGAUGE_VERSION
FRONT=127.0.0.1:$MESHGAUGE_GRPC_PORT
PROM=http://127.0.0.1:$MESHGAUGE_PROMETHEUS_PORT
# The reference's iterations, whose positions the clients cycle through.
ITERATIONS=${CHAOS_ITERATIONS:-30}
RESTARTS=${CHAOS_RESTARTS:-2}
PAUSE_SECONDS=${CHAOS_PAUSE_SECONDS:-20}
MAX_LATENCY=${CHAOS_MAX_LATENCY:-10}
REPORT=/tmp/meshgauge-chaos
mkdir -p "$REPORT"

# What an interrupted run left behind (this project only) goes first.
./stack.sh down --volumes >/dev/null 2>&1 || true
rm -rf "$CHAOS_HOME" "$MESHGAUGE_RUN_DIR"
mkdir -p "$CHAOS_HOME"
chmod 0755 "$CHAOS_HOME"
./stack.sh up 2
PLAIN_PID=
cleanup() {
  [ -n "$PLAIN_PID" ] && kill "$PLAIN_PID" 2>/dev/null || true
  ./stack.sh down --volumes >/dev/null 2>&1 || true
}
trap cleanup EXIT

retried() {  # retried attempts over the last $1 seconds, all replicas
  prom_query "$PROM" \
    "round(sum(increase(meshgauge_rpc_retried_attempts_total[${1}s])))"
}

/usr/bin/python3 plain_client.py --target "$FRONT" --ca "$MESHGAUGE_SECRETS_DIR/ca.crt" \
  --token-file "$MESHGAUGE_SECRETS_DIR/token" --sessions 2 --out "$REPORT/plain.json" \
  >"$REPORT/plain.log" 2>&1 &
PLAIN_PID=$!

healthy() {  # waits until N replicas report healthy
  for _ in $(seq 1 120); do
    [ "$(docker ps --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
          --filter label=com.docker.compose.service=meshgauge \
          --filter health=healthy -q | wc -l)" -ge "$1" ] && return 0
    sleep 1
  done
  echo "FAIL: fewer than $1 healthy replicas"; failed=1
}

failed=0
phase() {  # NAME "FAULT COMMAND" [LOAD FLAG...] (fault evaluated once the clients run)
  local name=$1 fault=$2
  shift 2
  local out="$REPORT/$name.txt" container="meshgauge-chaos-load-$name-$$"
  STACK_TOOL_NAME=$container stack_tool meshgauge-load \
    --target "$FRONT" --tls_ca_file /secrets/ca.crt \
    --token_file /secrets/token --clients 6 --iterations "$ITERATIONS" \
    --until_signal --frequency 16 --session_prefix "chaos-$name" \
    --time_limit_seconds 600 --progress_every 6 "$@" >"$out" 2>&1 &
  local load=$!
  # The fault comes once the clients have made calls (6 iterations).
  await_lines "$out" '^iterations:' 0 1200 ||
    { echo "FAIL: the clients made no progress"; failed=1; }
  local start=$SECONDS
  echo "== phase $name: $fault"
  eval "$fault" || { echo "FAIL: the fault command failed"; failed=1; }
  # Calls after the fault: 30 more iterations in all (about 5 per client),
  # then the clients stop.
  local progressed=0
  await_lines "$out" '^iterations:' $(($(grep -c '^iterations:' "$out") + 4)) 1200 ||
    progressed=1
  if ! kill -0 "$load" 2>/dev/null; then
    echo "FAIL: the load ended before it was told to stop"; failed=1
  elif ((progressed != 0)); then
    echo "FAIL: the clients made no progress after the fault"; failed=1
  fi
  docker kill --signal TERM "$container" >/dev/null 2>&1 || true
  local rc=0
  wait "$load" || rc=$?
  local end
  end=$(date +%s)
  await_prom "$PROM" "max(timestamp(up{job=\"meshgauge\"})) > $end" 300 ||
    echo "   (no scrape after the phase within 30 s)"
  local retries
  retries=$(retried $((SECONDS - start + 5)))
  echo "-- $name: $(grep -E '^calls:' "$out"), retried attempts ${retries:-0}"
  grep -E '^\| |^errors:|^  |mismatches|slower than|^PASS|^FAIL' "$out" |
    sed 's/^/   /'
  if [ "$rc" -ne 0 ] || ! grep -q "^errors: 0" "$out" ||
     ! grep -q "sessions lost: 0" "$out"; then
    echo "FAIL: phase $name"
    failed=1
  fi
}

healthy 2
# A crash: SIGKILL from outside the engine (`docker kill` would count as a
# manual stop and suspend the restart policy).
# The fault is over once the restart policy has brought the replica back.
phase kill 'kill -9 "$(docker inspect -f "{{.State.Pid}}" "$(stack_replica 1)")" && sleep 3 && healthy 2'
# The same crash under one big client whose every pass, VJP and penalty
# goes out in 2 parts, one per replica (meshgauge-load --fan_out 2): the
# part the killed replica held is asked again and the balancer sends it to
# the other; every merged reply is still the single-call reference's.
phase fanout 'kill -9 "$(docker inspect -f "{{.State.Pid}}" "$(stack_replica 2)")" && sleep 3 && healthy 2' \
  --clients 1 --fan_out 2 --frequency 40 --iterations 6 --progress_every 2
restarts() {  # graceful restarts of replica 2, 1, 2, ..., each healthy again
  for i in $(seq 1 "$RESTARTS"); do
    local r=$((2 - (i + 1) % 2))
    echo "   restart $i of $RESTARTS: replica $r"
    docker restart -t 30 "$(stack_replica "$r")" >/dev/null
    healthy 2
  done
}
phase restart restarts
healthy 2
phase scale './stack.sh scale 3 && healthy 3'
hang() {  # replica $1's server process stops for PAUSE_SECONDS, then goes on
  local pid
  pid=$(docker inspect -f '{{.State.Pid}}' "$(stack_replica "$1")")
  kill -STOP "$pid"
  sleep "$PAUSE_SECONDS"
  kill -CONT "$pid"
}
phase pause 'hang 2' --max_latency_seconds "$MAX_LATENCY"
healthy 3
phase stop 'docker stop -t 30 "$(stack_replica 1)" >/dev/null'
phase redis 'docker restart -t 10 "$(stack_containers redis)" >/dev/null'
attack() {
  /usr/bin/python3 attacker.py --target "$FRONT" \
    --ca "$MESHGAUGE_SECRETS_DIR/ca.crt" \
    --token-file "$MESHGAUGE_SECRETS_DIR/token" \
    --sessions "$(seq -s, -f 'chaos-attack-%g' 0 5)" | tee "$REPORT/attack.json"
}
phase attack attack --max_latency_seconds "$MAX_LATENCY"

kill -TERM "$PLAIN_PID"
wait "$PLAIN_PID" || true
PLAIN_PID=
echo "== plain gRPC client (UNAVAILABLE retry policy only): $(cat "$REPORT/plain.json")"
/usr/bin/python3 - "$REPORT/plain.json" <<'PY' || failed=1
import json, sys
c = json.load(open(sys.argv[1]))
if c.get("not_found", 0) or c.get("sessions", 0) < 2:
    sys.exit("FAIL: the plain client saw NOT_FOUND or lost its sessions")
PY
[ "$failed" -eq 0 ] || { echo "chaos test: FAIL"; exit 1; }
# The last stack of .ci/run: `down --prune` removes the build stage (the
# next `up` builds it again).
stage=$(stack_build_stage)
[ -n "$stage" ] || { echo "FAIL: no build stage image after up"; exit 1; }
./stack.sh down --volumes --prune
if docker image inspect "$stage" >/dev/null 2>&1; then
  echo "FAIL: down --prune kept the build stage"; exit 1; fi
echo "down --prune removed the build stage $stage"
echo "chaos test: PASS"
