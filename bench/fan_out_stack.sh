#!/usr/bin/env bash
# One pass of a big mesh through the compose stack (deploy/stack.sh: HAProxy,
# Redis, TLS, tokens, replicas limited to `cpus: 1.0` each): `meshgauge
# remote sdf MESH --fan-out 1` with one replica, then `--fan-out 2` after
# `stack.sh scale 2`; wall times and their ratio (issue 54;
# docs/deployment.md, "Fan-out through the balancer"). The images take the
# binaries of BUILD (MESHGAUGE_PREBUILT_FROM). Heavy (minutes), not in CI;
# needs Docker (deploy/ensure-docker.sh):
#   bench/fan_out_stack.sh BUILD MESH [RAYS] [ROUNDS]
# Its stack is a project of its own (meshgauge-fanout, gRPC port 50351,
# secrets in /tmp/meshgauge-fanout-test), brought down at the end. Each run
# uses its own cone angle (30 degrees plus a thousandth per run), so that no
# replica's cached pass or hits serve it (a new --kappa alone would reuse
# the hits of the pass before).
set -euo pipefail
build=$(realpath "$1") mesh=$(realpath "$2") rays=${3:-100} rounds=${4:-2}
cd "$(dirname "$0")/.."
export MESHGAUGE_PROJECT=meshgauge-fanout MESHGAUGE_GRPC_PORT=50351
export MESHGAUGE_PROMETHEUS_PORT=9390 MESHGAUGE_ALERTMANAGER_PORT=9393
export MESHGAUGE_SECRETS_DIR=/tmp/meshgauge-fanout-test/secrets
export MESHGAUGE_RUN_DIR=$PWD/deploy/.run/meshgauge-fanout
export MESHGAUGE_ALERT_WEBHOOK_URL=http://127.0.0.1:9/none
export MESHGAUGE_PREBUILT_FROM=$build
cli=$build/client/meshgauge
deploy/stack.sh down --volumes >/dev/null 2>&1 || true
rm -rf /tmp/meshgauge-fanout-test "$MESHGAUGE_RUN_DIR"
mkdir -p /tmp/meshgauge-fanout-test
trap 'deploy/stack.sh down --volumes >/dev/null 2>&1 || true' EXIT
deploy/stack.sh up 1 >/dev/null
remote() {
  "$cli" remote "$@" --server "127.0.0.1:$MESHGAUGE_GRPC_PORT" \
    --tls-ca-file "$MESHGAUGE_SECRETS_DIR/ca.crt" \
    --token-file "$MESHGAUGE_SECRETS_DIR/token"
}
seconds() {  # COMMAND...: its wall time
  local t0
  t0=$(date +%s.%N)
  "$@" >/dev/null
  awk -v t0="$t0" -v t1="$(date +%s.%N)" 'BEGIN { printf "%.2f", t1 - t0 }'
}
timed_pass() {  # K ROUND: one pass of the session `big` in K parts
  local angle
  angle=$(awk -v k="$1" -v r="$2" 'BEGIN { printf "%.3f", 30 + (10 * r + k) / 1000 }')
  seconds remote sdf "$mesh" --session-id big --rays "$rays" --cone-angle "$angle" --fan-out "$1"
}
echo "mesh $mesh: $(grep -c '^v ' "$mesh") vertices, $rays rays, replicas with cpus: 1.0"
echo "upload: $(seconds remote upload "$mesh" --session-id big) s"
one=()
for round in $(seq 1 "$rounds"); do
  one+=("$(timed_pass 1 "$round")")
  echo "1 replica, round $round, fan-out 1: ${one[-1]} s"
done
deploy/stack.sh scale 2 >/dev/null
for _ in $(seq 1 120); do  # the new replica healthy, then in the balancer
  [ "$(docker ps --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
        --filter label=com.docker.compose.service=meshgauge \
        --filter health=healthy -q | wc -l)" -ge 2 ] && break
  sleep 1
done
sleep 5
for round in $(seq 1 "$rounds"); do
  t=$(timed_pass 2 "$round")
  awk -v a="${one[$((round - 1))]}" -v b="$t" -v r="$round" \
    'BEGIN { printf "2 replicas, round %d, fan-out 2: %.2f s: ratio to round %d with 1 replica %.2f\n", r, b, r, a / b }'
done
