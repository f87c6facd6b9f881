#!/usr/bin/env bash
# One command: the stack test. It runs its own stack (project
# meshgauge-test, ports 50151, 9190, 9193, secrets in
# /tmp/meshgauge-stack-test, run directory deploy/.run/meshgauge-test; each
# settable, below) beside the operator's
# (project meshgauge, ports 50051, 9090, 9093, deploy/secrets), which it
# never touches: it records a session and the token of the operator's stack
# (starting a stand-in with one replica when none runs, removed at the end)
# and checks at the end that both still work and the secrets are unchanged.
# Its own stack: checks that `up` refuses a taken port before it starts
# anything, brings the stack up (deploy/stack.sh up 2: Redis, two replicas,
# HAProxy, Prometheus, Alertmanager, the blackbox and Redis exporters) with
# a certificate for an extra name, runs the smoke test with the CLI, checks
# that calls without the token or without TLS are refused, checks the
# secrets' validity, names and modes, runs the load test through the
# balancer while the secrets are rotated (stack.sh rotate-secrets, then
# --finish); after rotate-secrets, reload-balancer and scale (the verbs that
# signal containers) it SIGKILLs a replica, the balancer and Prometheus and
# requires each back by its restart policy; a second `up` must build
# nothing. Before those it checks Prometheus (replicas found by DNS, both serving, Redis,
# the balancer and its certificate scraped, the alert rules loaded), Redis'
# memory policy and private network, the containers' log rotation; backs
# Redis up three times under write load and restores a backup while the
# load runs (stack.sh backup-redis/restore-redis: no client error but the
# rollback's ABORTED); kills one replica and restarts the
# other three times and waits for the alerts MeshgaugeReplicasBelowDesired
# and MeshgaugeReplicaRestarting to fire, and for Alertmanager's
# notification of the first at a webhook (deploy/webhook_catcher.py);
# brings its stack down (also on failure), checking that `down` keeps the
# build stage and removes the stack's dangling images. The faults are
# deploy/chaos-test.sh's. Traffic goes to 127.0.0.1 only (the webhook
# listens on the host's interfaces, for the containers). Needs a Docker
# engine: deploy/ensure-docker.sh.
set -euo pipefail
cd "$(dirname "$0")"
source ../scripts/lib.sh
# The operator's settings (deploy/stack-lib.sh's defaults): the live stack
# this test must leave alone.
SETTINGS=(MESHGAUGE_PROJECT MESHGAUGE_GRPC_PORT MESHGAUGE_PROMETHEUS_PORT
          MESHGAUGE_ALERTMANAGER_PORT MESHGAUGE_SECRETS_DIR MESHGAUGE_RUN_DIR
          MESHGAUGE_ALERT_WEBHOOK_URL MESHGAUGE_CERT_NAMES)
as_operator() {  # COMMAND...: with the operator's (default) settings
  ( for v in "${SETTINGS[@]}"; do unset "$v"; done
    source ./stack-lib.sh
    "$@" )
}
# This test's stack.
TEST_HOME=${STACK_TEST_HOME:-/tmp/meshgauge-stack-test}
export MESHGAUGE_PROJECT=${STACK_TEST_PROJECT:-meshgauge-test}
export MESHGAUGE_GRPC_PORT=${STACK_TEST_GRPC_PORT:-50151}
export MESHGAUGE_PROMETHEUS_PORT=${STACK_TEST_PROMETHEUS_PORT:-9190}
export MESHGAUGE_ALERTMANAGER_PORT=${STACK_TEST_ALERTMANAGER_PORT:-9193}
# The run directory inside deploy/, as the operator's (deploy/.run): what
# stack.sh rewrites there must not reach the images' build context.
export MESHGAUGE_SECRETS_DIR=$TEST_HOME/secrets MESHGAUGE_RUN_DIR=$PWD/.run/$MESHGAUGE_PROJECT
# A name the operator configured for the certificate.
export MESHGAUGE_CERT_NAMES=127.0.0.1,localhost,meshgauge.test
WEBHOOK_PORT=$(free_port)
export MESHGAUGE_ALERT_WEBHOOK_URL=http://host.docker.internal:$WEBHOOK_PORT/meshgauge-alerts
source ./stack-lib.sh
FRONT=127.0.0.1:$MESHGAUGE_GRPC_PORT
PROM=http://127.0.0.1:$MESHGAUGE_PROMETHEUS_PORT
STAGE_START=$SECONDS
phase_time() { echo "   ($((SECONDS - STAGE_START)) s)"; }

# What an interrupted run of this test left behind (its containers come
# back with the engine) goes first: this project only.
./stack.sh down --volumes >/dev/null 2>&1 || true
docker ps -aq --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" |
  xargs -r docker rm -f >/dev/null
rm -rf "$TEST_HOME" "$MESHGAUGE_RUN_DIR"
mkdir -p "$TEST_HOME"
chmod 0755 "$TEST_HOME"

echo "== the operator's stack (project meshgauge): a session and its token"
LIVE_STARTED=0
if [ -z "$(as_operator stack_containers balancer)" ]; then
  echo "   none runs: a stand-in, one replica (removed at the end)"
  as_operator ./stack.sh up 1 >"$TEST_HOME/live-up.txt" 2>&1 ||
    { cat "$TEST_HOME/live-up.txt"; echo "FAIL: the stand-in operator stack did not come up"; exit 1; }
  LIVE_STARTED=1
fi
LIVE_SESSION=stack-test-live-$$
LIVE_TR=(--server 127.0.0.1:50051 --tls-ca-file /secrets/ca.crt --token-file /secrets/token)
as_operator stack_tool sh -c "meshgauge shape sphere --radius 0.5 --size 0.1 --out /tmp/s.obj >/dev/null &&
  meshgauge remote upload /tmp/s.obj --session-id $LIVE_SESSION ${LIVE_TR[*]} >/dev/null" ||
  { echo "FAIL: no session on the operator's stack"; exit 1; }
live_token=$(cat secrets/token)
live_secrets=$(cd secrets && cat ca.crt server.crt token replicas/tokens | sha256sum)
phase_time

WEBHOOK=
cleanup() {
  [ -z "$WEBHOOK" ] || kill "$WEBHOOK" 2>/dev/null || true
  ./stack.sh down --volumes >/dev/null 2>&1 || true
  if [ "$LIVE_STARTED" = 1 ]; then as_operator ./stack.sh down --volumes >/dev/null 2>&1 || true; fi
}
trap cleanup EXIT

# Alertmanager's receiver: a webhook on the host.
/usr/bin/python3 webhook_catcher.py "$WEBHOOK_PORT" "$TEST_HOME/notifications.jsonl" &
WEBHOOK=$!

echo "== up with port $MESHGAUGE_PROMETHEUS_PORT taken fails before it starts anything"
/usr/bin/python3 -c 'import socket,sys,time; s=socket.socket(); s.bind(("127.0.0.1",int(sys.argv[1]))); s.listen(); time.sleep(60)' "$MESHGAUGE_PROMETHEUS_PORT" &
squatter=$!
await_tcp "$MESHGAUGE_PROMETHEUS_PORT"
if ./stack.sh up 2 >"$TEST_HOME/taken.txt" 2>&1; then
  echo "FAIL: up succeeded with $MESHGAUGE_PROMETHEUS_PORT taken"; exit 1; fi
kill "$squatter"; wait "$squatter" 2>/dev/null || true
grep -q "port(s) $MESHGAUGE_PROMETHEUS_PORT already in use" "$TEST_HOME/taken.txt" ||
  { cat "$TEST_HOME/taken.txt"; echo "FAIL: up did not name the port"; exit 1; }
[ -z "$(docker ps -aq --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT")" ] ||
  { echo "FAIL: up left containers behind"; exit 1; }

./stack.sh up 2
phase_time

# Tools run from the meshgauge image on the host network (loopback only),
# as the operator's user (the token is theirs, mode 0600), with the stack's
# CA and token: TLS to the balancer, the token to the replicas.
TLS=(--tls-ca-file /secrets/ca.crt --token-file /secrets/token)
SECRETS=$MESHGAUGE_SECRETS_DIR

echo "== smoke test through the balancer ($FRONT)"
stack_tool sh -c "
  set -e
  R='--server $FRONT ${TLS[*]}'
  meshgauge shape sphere --radius 0.5 --size 0.05 --out /tmp/s.obj
  meshgauge remote upload /tmp/s.obj --session-id smoke \$R --json
  meshgauge remote sdf /tmp/s.obj --session-id smoke \$R --json
  meshgauge remote update smoke --positions /tmp/s.obj \$R --json
  meshgauge remote grad /tmp/s.obj --session-id smoke \$R --json
  meshgauge remote penalty /tmp/s.obj --session-id smoke --t-min 2 \$R --json
  meshgauge remote calibrate /tmp/s.obj --t-min 0.5 \$R
  meshgauge remote list \$R
  meshgauge remote delete smoke \$R"

echo "== without the token, or without TLS, the stack refuses"
if stack_tool meshgauge remote list --server "$FRONT" --tls-ca-file /secrets/ca.crt >/dev/null 2>&1; then
  echo "FAIL: a call without a token was served"; exit 1; fi
if stack_tool meshgauge remote list --server "$FRONT" >/dev/null 2>&1; then
  echo "FAIL: a plaintext call was served"; exit 1; fi

echo "== refused uploads end UNAUTHENTICATED through the balancer"
# A mesh of about 2 MB: the refusal comes while the client still sends,
# which HAProxy 2.6 alone would turn into CANCELLED.
refused=$(stack_tool sh -c "
  meshgauge shape sphere --radius 0.5 --size 0.01 --out /tmp/big.obj >/dev/null
  echo wrong-token >/tmp/wrong
  for i in 1 2 3 4 5 6 7 8 9 10; do
    meshgauge remote upload /tmp/big.obj --server $FRONT --tls-ca-file /secrets/ca.crt 2>&1 | tail -1
    meshgauge remote upload /tmp/big.obj --server $FRONT --tls-ca-file /secrets/ca.crt --token-file /tmp/wrong 2>&1 | tail -1
  done")
n=$(grep -c "^meshgauge: error: UNAUTHENTICATED: " <<<"$refused" || true)
echo "uploads without a token or with an unknown one: $n of 20 UNAUTHENTICATED"
[ "$n" -eq 20 ] || { sort <<<"$refused" | uniq -c; echo "FAIL: a refused upload did not end UNAUTHENTICATED"; exit 1; }

echo "== secrets: the certificate valid for a year and for the configured names, keys and token 0600"
date_of() { date -d "$(openssl x509 -noout "-$1" -in "$SECRETS/server.crt" | cut -d= -f2)" +%s; }
days=$(( ($(date_of enddate) - $(date_of startdate)) / 86400 ))
echo "server certificate: valid for $days days"
[ "$days" -ge 365 ] || { echo "FAIL: the certificate is valid for $days days"; exit 1; }
for f in ca.key server.key server.pem token balancer/server.pem; do
  [ "$(stat -c %a "$SECRETS/$f")" = 600 ] ||
    { echo "FAIL: secrets/$f is mode $(stat -c %a "$SECRETS/$f")"; exit 1; }
done
# The balancer serves a certificate a client verifying the host name
# meshgauge.test (MESHGAUGE_CERT_NAMES) accepts, and one verifying a name
# not configured refuses.
verifies() {  # HOSTNAME
  openssl s_client -connect "$FRONT" -CAfile "$SECRETS/ca.crt" -verify_hostname "$1" \
    -verify_return_error </dev/null >/dev/null 2>&1
}
verifies meshgauge.test || { echo "FAIL: the served certificate is not valid for meshgauge.test"; exit 1; }
if verifies other.test; then echo "FAIL: the certificate is valid for a name nobody configured"; exit 1; fi
echo "certificate names: $(cat "$SECRETS/server.names")"

echo "== load test through the balancer; the secrets are rotated meanwhile"
served() {  # the fingerprint of the certificate the balancer serves
  openssl s_client -connect "$FRONT" </dev/null 2>/dev/null |
    openssl x509 -noout -fingerprint -sha256 2>/dev/null
}
old_token=$(cat "$SECRETS/token")
# The load runs until it is stopped below (a fixed count of iterations could
# end before the rotation does once passes get faster).
rotation_load=meshgauge-stack-test-rotation-load-$$
STACK_TOOL_NAME=$rotation_load stack_tool meshgauge-load --target "$FRONT" \
  --tls_ca_file /secrets/ca.crt --token_file /secrets/token --clients 6 \
  --iterations 16 --frequency 16 --until_signal --time_limit_seconds 300 \
  --progress_every 6 >"$TEST_HOME/load.txt" 2>&1 &
load=$!
await_lines "$TEST_HOME/load.txt" '^iterations:' 0 1200 ||
  { cat "$TEST_HOME/load.txt"; echo "FAIL: the load made no progress"; exit 1; }
./stack.sh rotate-secrets
kill -0 "$load" 2>/dev/null ||
  { cat "$TEST_HOME/load.txt"; echo "FAIL: the load ended before the rotation did"; exit 1; }
new_fp=$(openssl x509 -noout -fingerprint -sha256 -in "$SECRETS/server.crt")
for _ in $(seq 1 100); do [ "$(served)" = "$new_fp" ] && break; sleep 0.1; done
[ "$(served)" = "$new_fp" ] || { echo "FAIL: the balancer serves the old certificate"; exit 1; }
stack_accepts_token "$(cat "$SECRETS/token")" || { echo "FAIL: the new token is refused"; exit 1; }
# At least the 6 clients' 16 iterations each (16 progress lines of 6), as
# the Prometheus checks below count, then the load is stopped.
await_lines "$TEST_HOME/load.txt" '^iterations:' 15 3000 ||
  { cat "$TEST_HOME/load.txt"; echo "FAIL: the load stalled after the rotation"; exit 1; }
docker kill --signal TERM "$rotation_load" >/dev/null 2>&1 || true
rc=0
wait "$load" || rc=$?
grep -v '^iterations:' "$TEST_HOME/load.txt"
[ "$rc" -eq 0 ] && grep -q "^errors: 0" "$TEST_HOME/load.txt" ||
  { echo "FAIL: the rotation cost the load client calls"; exit 1; }
stack_accepts_token "$old_token" || { echo "FAIL: the old token was refused before --finish"; exit 1; }
./stack.sh rotate-secrets --finish
for _ in $(seq 1 100); do stack_accepts_token "$old_token" || break; sleep 0.1; done
if stack_accepts_token "$old_token"; then echo "FAIL: the old token still works after --finish"; exit 1; fi
stack_accepts_token "$(cat "$SECRETS/token")" || { echo "FAIL: the new token is refused after --finish"; exit 1; }
echo "rotation: new certificate served, new token accepted, old token refused after --finish, 0 client errors"

phase_time

echo "== Prometheus"
q() { prom_query "$PROM" "$1"; }
# Both replicas found by DNS, and a scrape after the load's 112 ComputeSdf
# (the reference's 16, then at least 96).
await_prom "$PROM" 'meshgauge:replicas_up == 2' 300 || true
await_prom "$PROM" 'sum(meshgauge_rpc_requests_total{method="ComputeSdf"}) >= 112' 300 || true
up=$(q 'meshgauge:replicas_up')
echo "replicas up: ${up:-0}"
[ "${up:-0}" = "2" ] || { echo "FAIL: Prometheus does not see both replicas up"; exit 1; }
serving=$(q 'count(sum by (instance) (meshgauge_rpc_requests_total{method="ComputeSdf"}) > 0)')
# 8 sessions hashed over 2 replicas all land on one with probability 1/128:
# reported, not a failure.
echo "replicas that served ComputeSdf: ${serving:-0} of 2"
[ "${serving:-0}" -ge 1 ] || { echo "FAIL: no replica metrics in Prometheus"; exit 1; }
[ "$(q 'redis_up')" = "1" ] || { echo "FAIL: Redis is not up in Prometheus"; exit 1; }
await_prom "$PROM" 'up{job="balancer"} == 1' 300 ||
  { echo "FAIL: Prometheus does not scrape the balancer"; exit 1; }
await_prom "$PROM" 'probe_ssl_earliest_cert_expiry{job="balancer-tls"} - time() > 300 * 86400' 600 ||
  { echo "FAIL: no certificate expiry from the balancer's TLS probe"; exit 1; }
echo "balancer scraped; its certificate expires in $(q 'round((probe_ssl_earliest_cert_expiry - time()) / 86400)') days"
[ "$(q 'redis_memory_max_bytes')" = "$((640 * 1024 * 1024))" ] ||
  { echo "FAIL: Redis' maxmemory is $(q 'redis_memory_max_bytes')"; exit 1; }
redis=$(stack_containers redis)
[ "$(docker exec "$redis" redis-cli CONFIG GET maxmemory-policy | tail -1)" = noeviction ] ||
  { echo "FAIL: Redis may evict sessions"; exit 1; }
echo "Redis: maxmemory 640 MB, noeviction"
# Redis only on the private network: the replicas reach it, the balancer
# cannot even resolve it, and it publishes no port.
reach_redis() { docker exec "$1" bash -c 'exec 3<>/dev/tcp/redis/6379' 2>/dev/null; }
reach_redis "$(stack_replica 1)" || { echo "FAIL: a replica cannot reach Redis"; exit 1; }
if reach_redis "$(stack_containers balancer)"; then echo "FAIL: the balancer reaches Redis"; exit 1; fi
[ -z "$(docker port "$redis")" ] || { echo "FAIL: Redis publishes a port"; exit 1; }
echo "Redis: reachable from the replicas only"
for c in $(docker ps -q --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT"); do
  [ "$(docker inspect -f '{{.HostConfig.LogConfig.Type}} {{index .HostConfig.LogConfig.Config "max-size"}} {{index .HostConfig.LogConfig.Config "max-file"}}' "$c")" = "json-file 10m 3" ] ||
    { docker inspect -f '{{.Name}} {{.HostConfig.LogConfig}}' "$c"; echo "FAIL: a container's log is not rotated"; exit 1; }
done
echo "logs: every container rotates at 10 MB, 3 files"
rules=$(curl -sf "$PROM/api/v1/rules" | grep -o '"name":"Meshgauge[A-Za-z0-9]*"' | sort -u | wc -l)
echo "alert rules loaded: $rules"
[ "$rules" -ge 14 ] || { echo "FAIL: alert rules not loaded"; exit 1; }
phase_time

echo "== restart policies hold after the verbs that signal containers"
# After each verb, a replica, the balancer and Prometheus are SIGKILLed from
# the host (a crash); each must be running again by itself (unless-stopped).
# Signals sent with docker kill -s, as stack.sh did, disable that on
# Docker 20.10 (the container stayed Exited (137)).
crash_all() {  # VERB: after it, crash and wait for the restarts
  local s c n
  declare -A count name
  for s in meshgauge balancer prometheus; do
    c=$(stack_containers "$s" | head -1)
    [ -n "$c" ] || { echo "FAIL: no running $s after $1"; exit 1; }
    count[$c]=$(docker inspect -f '{{.RestartCount}}' "$c")
    name[$c]=$s
    kill -9 "$(docker inspect -f '{{.State.Pid}}' "$c")"
  done
  for c in "${!count[@]}"; do
    for _ in $(seq 1 150); do
      n=$(docker inspect -f '{{.State.Running}} {{.RestartCount}}' "$c")
      [ "$n" = "true $((count[$c] + 1))" ] && break
      sleep 0.2
    done
    [ "$n" = "true $((count[$c] + 1))" ] || {
      docker ps -a --filter "id=$c"
      echo "FAIL: ${name[$c]} stayed down after a crash following stack.sh $1"; exit 1; }
  done
  echo "after $1: replica, balancer and Prometheus crashed and came back"
}
healthy() {  # waits until N replicas and the balancer report healthy
  for _ in $(seq 1 120); do
    [ "$(docker ps --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
          --filter label=com.docker.compose.service=meshgauge \
          --filter health=healthy -q | wc -l)" -ge "$1" ] &&
      [ -n "$(docker ps --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
          --filter label=com.docker.compose.service=balancer --filter health=healthy -q)" ] &&
      return 0
    sleep 0.5
  done
  echo "FAIL: fewer than $1 healthy replicas, or the balancer unhealthy"; exit 1
}
# (A container a signal disabled stays so until it is started again: the
# crash after the Prometheus checks still sees the rotation's signals.)
crash_all rotate-secrets
./stack.sh reload-balancer
crash_all reload-balancer
./stack.sh scale 3
crash_all scale
healthy 3
phase_time

echo "== a second up builds nothing (the build cache holds after scale)"
images() {
  local i
  for i in meshgauge meshgauge-redis meshgauge-balancer meshgauge-prometheus; do
    docker image inspect -f '{{.Id}}' "$i:$(meshgauge_version)"
  done
}
before=$(images)
./stack.sh up 2 >"$TEST_HOME/up-again.txt" 2>&1 ||
  { cat "$TEST_HOME/up-again.txt"; echo "FAIL: the second up failed"; exit 1; }
ran=$(grep -c -- '---> Running in' "$TEST_HOME/up-again.txt" || true)
[ "$(images)" = "$before" ] && [ "$ran" -eq 0 ] || {
  grep -B3 -- '---> Running in' "$TEST_HOME/up-again.txt" | head -20
  echo "FAIL: the second up built again ($ran steps ran; images changed: $([ "$(images)" = "$before" ] && echo no || echo yes))"; exit 1; }
echo "second up: $(grep -c 'Using cache' "$TEST_HOME/up-again.txt") steps from the cache, none run, images unchanged"
healthy 2
phase_time

echo "== Redis: three backups under write load, a restore brings back a deleted session"
stack_tool sh -c "meshgauge shape sphere --radius 0.5 --size 0.1 --out /tmp/s.obj >/dev/null &&
  meshgauge remote upload /tmp/s.obj --session-id kept --server $FRONT ${TLS[*]} >/dev/null"
listed() { stack_tool meshgauge remote list --server "$FRONT" "${TLS[@]}" 2>/dev/null || true; }
STACK_TOOL_NAME=meshgauge-stack-test-backup-load-$$ stack_tool meshgauge-load \
  --target "$FRONT" --tls_ca_file /secrets/ca.crt --token_file /secrets/token \
  --clients 4 --iterations 8 --frequency 12 --until_signal --session_prefix backup \
  --time_limit_seconds 300 --progress_every 4 >"$TEST_HOME/backup-load.txt" 2>&1 &
load=$!
await_lines "$TEST_HOME/backup-load.txt" '^iterations:' 0 1200 ||
  { cat "$TEST_HOME/backup-load.txt"; echo "FAIL: the load made no progress"; exit 1; }
backup_dir=$TEST_HOME/backups
mkdir -p "$backup_dir"
for i in 1 2 3; do
  ./stack.sh backup-redis "$backup_dir/redis-$i.tgz" ||
    { echo "FAIL: backup $i under load failed"; exit 1; }
done
kill -0 "$load" 2>/dev/null || { echo "FAIL: the load ended before the backups did"; exit 1; }
tar tzf "$backup_dir/redis-3.tgz" | grep -qx dump.rdb || { echo "FAIL: no dump.rdb in the backup"; exit 1; }
stack_tool meshgauge remote delete kept --server "$FRONT" "${TLS[@]}"
listed | grep -q '^kept ' && { echo "FAIL: the session was not deleted"; exit 1; }
# The restore, while the clients go on: it rolls their sessions back to the
# snapshot, so an update expecting a later generation ends ABORTED; none may
# fail for the outage itself (UNAVAILABLE beyond the clients' retries).
n=$(grep -c '^iterations:' "$TEST_HOME/backup-load.txt")
./stack.sh restore-redis "$backup_dir/redis-3.tgz"
await_lines "$TEST_HOME/backup-load.txt" '^iterations:' $((n + 1)) 300 || true
docker kill --signal TERM "meshgauge-stack-test-backup-load-$$" >/dev/null 2>&1 || true
wait "$load" || true
echo "backups under load: 3 of 3 succeeded; the load ($(grep -E '^calls:' "$TEST_HOME/backup-load.txt")) saw:"
grep -E '^errors:|^  [A-Za-z]+ [A-Z_]+: ' "$TEST_HOME/backup-load.txt" | sed 's/^/   /'
if grep -E '^  [A-Za-z]+ [A-Z_]+: ' "$TEST_HOME/backup-load.txt" | grep -vE '^  [A-Za-z]+ (ABORTED|NOT_FOUND): '; then
  echo "FAIL: the backups or the restore cost the clients calls (other than the rollback's ABORTED)"; exit 1; fi
for _ in $(seq 1 20); do listed | grep -q '^kept ' && break; sleep 0.5; done
listed | grep -q '^kept ' || { echo "FAIL: the restored backup lacks the session"; exit 1; }
echo "backup and restore: the session is back"
phase_time

echo "== alerts: replica 2 killed (it stays down), replica 1 restarting in a loop"
docker kill "$(stack_replica 2)" >/dev/null
for i in 1 2 3; do
  docker restart -t 0 "$(stack_replica 1)" >/dev/null
  await_prom "$PROM" "meshgauge:restarts_15m >= $i" 300 ||
    { echo "FAIL: Prometheus did not see restart $i of replica 1"; exit 1; }
done
firing() { await_prom "$PROM" "ALERTS{alertname=\"$1\",alertstate=\"firing\"}" 600; }
firing MeshgaugeReplicaRestarting ||
  { echo "FAIL: MeshgaugeReplicaRestarting did not fire"; exit 1; }
echo "MeshgaugeReplicaRestarting: firing"
firing MeshgaugeReplicasBelowDesired || {
  # What Prometheus saw, for the next reader of a failed run.
  echo "Prometheus: $(q 'meshgauge:replicas_up') meshgauge targets up (scraped within 30 s) of $(q 'count(up{job="meshgauge"})') series, $(q 'count(up{job="meshgauge"} == 1)') of them 1; desired $(q 'meshgauge:replicas_desired'); running replicas: $(stack_containers meshgauge | wc -l)"
  echo "its meshgauge targets: $(curl -s "$PROM/api/v1/targets?state=active" | grep -o '"scrapeUrl":"[^"]*"' | grep -v -e balancer -e redis -e prometheus | tr '\n' ' ')"
  echo "the project's replicas (all states): $(docker ps -a --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" --filter label=com.docker.compose.service=meshgauge --format '{{.Names}} {{.Status}}' | tr '\n' ';') addresses: $(for c in $(docker ps -aq --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" --filter label=com.docker.compose.service=meshgauge); do docker inspect -f '{{range .NetworkSettings.Networks}}{{.IPAddress}} {{end}}' "$c"; done | tr '\n' ' ')"
  echo "FAIL: MeshgaugeReplicasBelowDesired did not fire within 60 s"; exit 1; }
echo "MeshgaugeReplicasBelowDesired: firing ($(q 'meshgauge:replicas_up') of $(q 'meshgauge:replicas_desired') up)"
# Alertmanager's notification at the webhook (group_wait 10 s).
notified() {
  grep -h '"status": "firing"' "$TEST_HOME/notifications.jsonl" 2>/dev/null |
    grep -q "\"alertname\": \"$1\""
}
for _ in $(seq 1 120); do notified MeshgaugeReplicasBelowDesired && break; sleep 0.5; done
notified MeshgaugeReplicasBelowDesired ||
  { cat "$TEST_HOME/notifications.jsonl" 2>/dev/null | cut -c1-300; echo "FAIL: no notification of MeshgaugeReplicasBelowDesired at the webhook"; exit 1; }
echo "webhook: notified of MeshgaugeReplicasBelowDesired ($(wc -l <"$TEST_HOME/notifications.jsonl") notifications in all)"
# Its container health check (every 5 s, for the whole test) speaks plain
# HTTP to a loopback monitor: no connection closed during a TLS handshake
# (what a TCP check of the TLS port logs) in its log.
balancer=$(docker ps -q --filter label=com.docker.compose.project=meshgauge \
  --filter label=com.docker.compose.service=balancer)
if docker logs "$balancer" 2>&1 | grep "Connection closed during SSL handshake"; then
  echo "FAIL: the balancer logs connections closed during TLS handshakes"; exit 1; fi
echo "== down keeps the build stage (the next up's cache) and removes the stack's dangling images"
stage=$(stack_build_stage)
[ -n "$stage" ] || { echo "FAIL: no build stage image after up"; exit 1; }
# A dangling image of the stack, as a rebuild leaves the one it replaced.
dangling=$(printf 'FROM meshgauge-redis:%s\nLABEL meshgauge.test=dangling\n' "$(meshgauge_version)" |
  docker build -q - 2>/dev/null)
[ -n "$dangling" ] || { echo "FAIL: could not make a dangling image"; exit 1; }
./stack.sh down --volumes
docker image inspect "$stage" >/dev/null 2>&1 ||
  { echo "FAIL: down removed the build stage"; exit 1; }
if docker image inspect "$dangling" >/dev/null 2>&1; then
  echo "FAIL: down kept a dangling image of the stack"; exit 1; fi
echo "down kept the build stage $stage and removed the dangling image (the chaos test checks down --prune)"

echo "== the operator's stack was not touched"
live_ok=1
as_operator stack_tool meshgauge remote list "${LIVE_TR[@]}" 2>/dev/null | grep -q "^$LIVE_SESSION " ||
  { echo "FAIL: the operator's session is gone"; live_ok=0; }
MESHGAUGE_TOKEN=$live_token as_operator stack_accepts_token "$live_token" ||
  { echo "FAIL: the operator's token is refused"; live_ok=0; }
[ "$(cd secrets && cat ca.crt server.crt token replicas/tokens | sha256sum)" = "$live_secrets" ] ||
  { echo "FAIL: deploy/secrets changed"; live_ok=0; }
as_operator stack_tool meshgauge remote delete "$LIVE_SESSION" "${LIVE_TR[@]}" >/dev/null 2>&1 || true
[ "$live_ok" = 1 ] || exit 1
echo "operator's stack: its session and token still work, deploy/secrets unchanged"
phase_time
echo "stack test: PASS"
