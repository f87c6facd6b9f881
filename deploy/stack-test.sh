#!/usr/bin/env bash
# One command: checks that `up` refuses a taken port before it starts
# anything, brings the stack up (deploy/stack.sh up 2: Redis, two
# replicas, HAProxy, Prometheus), runs the smoke test with the CLI, checks
# that calls without the token or without TLS are refused, checks the
# secrets' validity and modes, runs the load test through the balancer while
# the secrets are rotated (stack.sh rotate-secrets, then --finish), checks
# Prometheus, restores a Redis backup (stack.sh backup-redis/restore-redis), checks Prometheus (replicas found by DNS, both
# serving, Redis up, the alert rules loaded), kills one replica and
# restarts the other three times and waits for the alerts
# MeshgaugeReplicasBelowDesired and MeshgaugeReplicaRestarting to fire, and
# brings the stack down (also on failure), checking that `down` keeps the
# build stage. The faults are deploy/chaos-test.sh's. Traffic goes to
# 127.0.0.1 only. Needs a Docker engine: deploy/ensure-docker.sh.
set -euo pipefail
cd "$(dirname "$0")"
source ../scripts/lib.sh
FRONT=127.0.0.1:50051
PROM=http://127.0.0.1:9090

# A stack an interrupted run left behind (its containers come back with the
# engine) is not this test's: it goes first.
./stack.sh down --volumes >/dev/null 2>&1 || true
docker ps -aq --filter label=com.docker.compose.project=meshgauge |
  xargs -r docker rm -f >/dev/null

echo "== up with port 9090 taken fails before it starts anything"
/usr/bin/python3 -c 'import socket,time; s=socket.socket(); s.bind(("127.0.0.1",9090)); s.listen(); time.sleep(60)' &
squatter=$!
await_tcp 9090
if ./stack.sh up 2 >/tmp/meshgauge-stack-taken.txt 2>&1; then
  echo "FAIL: up succeeded with 9090 taken"; exit 1; fi
kill "$squatter"; wait "$squatter" 2>/dev/null || true
grep -q "port(s) 9090 already in use" /tmp/meshgauge-stack-taken.txt ||
  { cat /tmp/meshgauge-stack-taken.txt; echo "FAIL: up did not name the port"; exit 1; }
[ -z "$(docker ps -aq --filter label=com.docker.compose.project=meshgauge)" ] ||
  { echo "FAIL: up left containers behind"; exit 1; }

./stack.sh up 2
cleanup() { ./stack.sh down --volumes >/dev/null 2>&1 || true; }
trap cleanup EXIT

# Tools run from the meshgauge image on the host network (loopback only),
# as the operator's user (the token is theirs, mode 0600), with the stack's
# CA and token: TLS to the balancer, the token to the replicas.
TLS=(--tls-ca-file /secrets/ca.crt --token-file /secrets/token)

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

echo "== secrets: the certificate valid for a year, keys and token 0600"
date_of() { date -d "$(openssl x509 -noout "-$1" -in secrets/server.crt | cut -d= -f2)" +%s; }
days=$(( ($(date_of enddate) - $(date_of startdate)) / 86400 ))
echo "server certificate: valid for $days days"
[ "$days" -ge 365 ] || { echo "FAIL: the certificate is valid for $days days"; exit 1; }
for f in ca.key server.key server.pem token balancer/server.pem; do
  [ "$(stat -c %a "secrets/$f")" = 600 ] ||
    { echo "FAIL: secrets/$f is mode $(stat -c %a "secrets/$f")"; exit 1; }
done

echo "== load test through the balancer; the secrets are rotated meanwhile"
served() {  # the fingerprint of the certificate the balancer serves
  openssl s_client -connect "$FRONT" </dev/null 2>/dev/null |
    openssl x509 -noout -fingerprint -sha256 2>/dev/null
}
old_token=$(cat secrets/token)
stack_tool meshgauge-load --target "$FRONT" --tls_ca_file /secrets/ca.crt \
  --token_file /secrets/token --clients 6 --iterations 16 --frequency 16 \
  --time_limit_seconds 300 --progress_every 6 >/tmp/meshgauge-load-stack.txt 2>&1 &
load=$!
await_lines /tmp/meshgauge-load-stack.txt '^iterations:' 0 1200 ||
  { cat /tmp/meshgauge-load-stack.txt; echo "FAIL: the load made no progress"; exit 1; }
./stack.sh rotate-secrets
kill -0 "$load" 2>/dev/null ||
  { echo "FAIL: the load ended before the rotation did (too short to test it)"; exit 1; }
new_fp=$(openssl x509 -noout -fingerprint -sha256 -in secrets/server.crt)
for _ in $(seq 1 100); do [ "$(served)" = "$new_fp" ] && break; sleep 0.1; done
[ "$(served)" = "$new_fp" ] || { echo "FAIL: the balancer serves the old certificate"; exit 1; }
stack_accepts_token "$(cat secrets/token)" || { echo "FAIL: the new token is refused"; exit 1; }
rc=0
wait "$load" || rc=$?
grep -v '^iterations:' /tmp/meshgauge-load-stack.txt
[ "$rc" -eq 0 ] && grep -q "^errors: 0" /tmp/meshgauge-load-stack.txt ||
  { echo "FAIL: the rotation cost the load client calls"; exit 1; }
stack_accepts_token "$old_token" || { echo "FAIL: the old token was refused before --finish"; exit 1; }
./stack.sh rotate-secrets --finish
for _ in $(seq 1 100); do stack_accepts_token "$old_token" || break; sleep 0.1; done
if stack_accepts_token "$old_token"; then echo "FAIL: the old token still works after --finish"; exit 1; fi
stack_accepts_token "$(cat secrets/token)" || { echo "FAIL: the new token is refused after --finish"; exit 1; }
echo "rotation: new certificate served, new token accepted, old token refused after --finish, 0 client errors"

echo "== Prometheus"
q() { prom_query "$PROM" "$1"; }
# Both replicas found by DNS, and a scrape after the load's 112 ComputeSdf.
await_prom "$PROM" 'count(up{job="meshgauge"} == 1) == 2' 300 || true
await_prom "$PROM" 'sum(meshgauge_rpc_requests_total{method="ComputeSdf"}) >= 112' 300 || true
up=$(q 'count(up{job="meshgauge"} == 1)')
echo "replicas up: ${up:-0}"
[ "${up:-0}" = "2" ] || { echo "FAIL: Prometheus does not see both replicas up"; exit 1; }
serving=$(q 'count(sum by (instance) (meshgauge_rpc_requests_total{method="ComputeSdf"}) > 0)')
# 8 sessions hashed over 2 replicas all land on one with probability 1/128:
# reported, not a failure.
echo "replicas that served ComputeSdf: ${serving:-0} of 2"
[ "${serving:-0}" -ge 1 ] || { echo "FAIL: no replica metrics in Prometheus"; exit 1; }
[ "$(q 'redis_up')" = "1" ] || { echo "FAIL: Redis is not up in Prometheus"; exit 1; }
rules=$(curl -sf "$PROM/api/v1/rules" | grep -o '"name":"Meshgauge[A-Za-z0-9]*"' | sort -u | wc -l)
echo "alert rules loaded: $rules"
[ "$rules" -ge 5 ] || { echo "FAIL: alert rules not loaded"; exit 1; }

echo "== Redis: a backup restored brings back a deleted session"
stack_tool sh -c "meshgauge shape sphere --radius 0.5 --size 0.1 --out /tmp/s.obj >/dev/null &&
  meshgauge remote upload /tmp/s.obj --session-id kept --server $FRONT ${TLS[*]} >/dev/null"
listed() { stack_tool meshgauge remote list --server "$FRONT" "${TLS[@]}" 2>/dev/null || true; }
backup=$(mktemp -d)/redis.tgz
./stack.sh backup-redis "$backup"
stack_tool meshgauge remote delete kept --server "$FRONT" "${TLS[@]}"
listed | grep -q '^kept ' && { echo "FAIL: the session was not deleted"; exit 1; }
./stack.sh restore-redis "$backup"
for _ in $(seq 1 20); do listed | grep -q '^kept ' && break; sleep 0.5; done
listed | grep -q '^kept ' || { echo "FAIL: the restored backup lacks the session"; exit 1; }
rm -rf "$(dirname "$backup")"
echo "backup and restore: the session is back"

echo "== alerts: replica 2 killed (it stays down), replica 1 restarting in a loop"
docker kill "$(stack_replica 2)" >/dev/null
for i in 1 2 3; do
  docker restart -t 0 "$(stack_replica 1)" >/dev/null
  await_prom "$PROM" "changes(process_start_time_seconds{job=\"meshgauge\"}[15m]) >= $i" 300 ||
    { echo "FAIL: Prometheus did not see restart $i of replica 1"; exit 1; }
done
firing() { await_prom "$PROM" "ALERTS{alertname=\"$1\",alertstate=\"firing\"}" 600; }
firing MeshgaugeReplicaRestarting ||
  { echo "FAIL: MeshgaugeReplicaRestarting did not fire"; exit 1; }
echo "MeshgaugeReplicaRestarting: firing"
firing MeshgaugeReplicasBelowDesired ||
  { echo "FAIL: MeshgaugeReplicasBelowDesired did not fire within 60 s"; exit 1; }
echo "MeshgaugeReplicasBelowDesired: firing ($(q 'count(up{job="meshgauge"} == 1)') of $(q 'meshgauge:replicas_desired') up)"
# Its container health check (every 5 s, for the whole test) speaks plain
# HTTP to a loopback monitor: no connection closed during a TLS handshake
# (what a TCP check of the TLS port logs) in its log.
balancer=$(docker ps -q --filter label=com.docker.compose.project=meshgauge \
  --filter label=com.docker.compose.service=balancer)
if docker logs "$balancer" 2>&1 | grep "Connection closed during SSL handshake"; then
  echo "FAIL: the balancer logs connections closed during TLS handshakes"; exit 1; fi
echo "== down keeps the build stage (the next up's cache)"
stage=$(stack_build_stage)
[ -n "$stage" ] || { echo "FAIL: no build stage image after up"; exit 1; }
./stack.sh down --volumes
docker image inspect "$stage" >/dev/null 2>&1 ||
  { echo "FAIL: down removed the build stage"; exit 1; }
echo "down kept the build stage $stage (the chaos test checks down --prune)"
echo "stack test: PASS"
