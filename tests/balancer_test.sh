#!/usr/bin/env bash
# The deployment's balancer in front of two replicas: what clients see when
# a replica stops, hangs, or refuses an upload, and when the balancer
# reloads. HAProxy runs deploy/haproxy/haproxy.cfg with its backend and
# health check unchanged (only the listener and the two replicas' addresses
# are made local); the replicas share sessions through Redis and check
# tokens. meshgauge-load's clients iterate through the balancer.
# - Graceful stops: each replica in turn gets SIGTERM (health NOT_SERVING
#   for its 4 s drain notice, then drain and stop) and is started again.
#   Pass, per stop: the balancer takes it out of the rotation ("is
#   stopping": its calls go on) within 3.5 s, while it still serves (so no
#   call reaches it as gRPC shuts down, where it would end CANCELLED), and
#   UP again after its restart; the clients see 0 errors.
# - A hung replica: replica 0's process is stopped (SIGSTOP) for 12 s. Pass:
#   the balancer marks it DOWN, which ends its calls (they are retried on
#   replica 1), no call takes longer than 8 s, 0 errors.
# - Refused uploads: 10 uploads of a 2 MB mesh without a token and 10 with
#   an unknown one end UNAUTHENTICATED every time (not CANCELLED: see
#   MeshGaugeService::DiscardRest).
# - Reloads: the balancer itself is reloaded (SIGUSR2 to its master
#   process, as `deploy/stack.sh reload-balancer` does) three times under a
#   load whose clients do not retry: 0 errors.
# - Restarts: the balancer soft-stops (SIGUSR1, as `docker stop` and
#   `docker restart` do) and a new one starts, twice, under a load whose
#   clients do not retry: 0 errors.
# - Fan-out: `meshgauge remote grad --fan-out 2` of four sessions: each
#   session's two parts reach different replicas and each part's VJP the
#   replica of its pass (the request lines of the balancer's log, at level
#   info here, name the replica and the part).
# - Big client: meshgauge-load --fan_out 2 --clients 1: 0 errors, every
#   fanned-out reply the single-call reference's bit for bit.
# Every load also checks 0 mismatches and 0 lost sessions.
#   balancer_test.sh SERVER LOAD CLI CFG [CYCLES]
set -euo pipefail
server=$1 load=$2 cli=$3 cfg=$4 cycles=${5:-2}
for tool in haproxy redis-server; do
  command -v "$tool" >/dev/null || { echo "needs $tool (scripts/install_deps.sh)"; exit 1; }
done
tmp=$(mktemp -d)
pids=()
cleanup() { kill -CONT "${pids[@]}" 2>/dev/null || true; kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$tmp"; }
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
token=balancer-test-token
echo "$token" >"$tmp/token"
echo "tenant-a $(printf %s "$token" | sha256sum | cut -d' ' -f1)" >"$tmp/tokens"

# Each replica binds port 0 first and keeps the port it got on restarts
# (the balancer's configuration names it).
ports=(0 0)
replica_pid=()
start_replica() {  # INDEX
  rm -f "$tmp/port$1"
  "$server" --address "127.0.0.1:${ports[$1]}" --metrics_address= \
    --port_file "$tmp/port$1" \
    --session_store "redis://127.0.0.1:$redis_port" --drain_notice_seconds=4 \
    --auth_tokens_file "$tmp/tokens" \
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
    -e "s|^ *log stderr format raw local0 warning|  log stderr format raw local0 info|" \
    "$cfg" >"$tmp/haproxy.cfg"
start_balancer() {
  haproxy -W -db -f "$tmp/haproxy.cfg" 2>>"$tmp/haproxy.log" &
  haproxy_pid=$!
  pids+=($!)
  await_tcp "$hp"
}
start_balancer
# The balancer's own health: plain HTTP 200 on its health port.
curl -sf "http://127.0.0.1:$health_port/healthz" >/dev/null ||
  fail "the balancer's health frontend did not answer 200"

# Waits for the load's clients to start (after its single-client reference
# run, which takes long on a busy machine), then for 8 more
# iterations (2 progress lines); $1 names the moment for the failure message.
await_progress() {
  local before
  await_lines "$tmp/load.txt" '^concurrent phase: started' 0 1800 ||
    fail "the load's clients had not started $1"
  before=$(grep -c '^iterations:' "$tmp/load.txt" || true)
  await_lines "$tmp/load.txt" '^iterations:' $((before + 2)) 300 ||
    fail "the load made no progress $1"
  kill -0 "$load_pid" 2>/dev/null || fail "the load ended $1"
}
# Stops the load (its clients end their iteration) and waits for it; fails
# with $1 unless it saw no error.
finish_load() {
  local rc=0
  kill -TERM "$load_pid" 2>/dev/null || true
  wait "$load_pid" || rc=$?
  sed -n '/^errors:/,$p' "$tmp/load.txt"
  [ "$rc" -eq 0 ] && grep -q "^errors: 0" "$tmp/load.txt" || fail "$1"
}

# ITERATIONS PREFIX [FLAG...]: meshgauge-load through the balancer, its
# clients cycling through ITERATIONS positions until finish_load stops them
# (a fixed count ran out before the second stop once the passes got faster).
start_load() {
  local iterations=$1 prefix=$2
  shift 2
  : >"$tmp/load.txt"  # no line of the previous load is counted.
  "$load" --target "127.0.0.1:$hp" --clients 4 --iterations "$iterations" \
    --until_signal \
    --frequency 4 --session_prefix "$prefix" --time_limit_seconds 120 \
    --token_file "$tmp/token" --progress_every 4 "$@" >"$tmp/load.txt" 2>&1 &
  load_pid=$!
}
since() { awk -v t0="$1" -v t1="$(date +%s.%N)" 'BEGIN { printf "%.2f", t1 - t0 }'; }

start_load 150 drain
for c in $(seq 1 "$cycles"); do
  r=$((c % 2))
  await_progress "before stop $c"  # through both replicas.
  stopping=$(grep -c "meshgauge/r$r is stopping" "$tmp/haproxy.log" || true)
  ups=$(grep -c "meshgauge/r$r is UP" "$tmp/haproxy.log" || true)
  t0=$(date +%s.%N)
  kill -TERM "${replica_pid[$r]}"
  await_log "meshgauge/r$r is stopping" 35 "$stopping" ||
    fail "3.5 s after SIGTERM the balancer still routes to replica $r"
  echo "stop $c: replica $r out of the rotation $(since "$t0") s after SIGTERM"
  kill -0 "${replica_pid[$r]}" 2>/dev/null ||
    fail "replica $r stopped before the balancer took it out of the rotation"
  wait "${replica_pid[$r]}" || true
  start_replica "$r"
  await_log "meshgauge/r$r is UP" 100 "$ups" ||
    fail "the balancer did not take replica $r back within 10 s"
done
finish_load "a graceful stop cost the clients calls"
echo "PASS: $cycles graceful stops, each replica left the balancer before it stopped, no client saw an error"

start_load 800 hung --max_latency_seconds 8
await_progress "before the hang"
downs=$(grep -c "meshgauge/r0 is DOWN" "$tmp/haproxy.log" || true)
ups=$(grep -c "meshgauge/r0 is UP" "$tmp/haproxy.log" || true)
t0=$(date +%s.%N)
kill -STOP "${replica_pid[0]}"
await_log "meshgauge/r0 is DOWN" 80 "$downs" ||
  { kill -CONT "${replica_pid[0]}"; fail "8 s after it hung the balancer still routes to replica 0"; }
echo "hang: replica 0 DOWN $(since "$t0") s after SIGSTOP"
await_progress "while replica 0 hangs"
sleep "$(awk -v t="$(since "$t0")" 'BEGIN { print (t < 12 ? 12 - t : 0) }')"
kill -CONT "${replica_pid[0]}"
await_log "meshgauge/r0 is UP" 100 "$ups" ||
  fail "the balancer did not take replica 0 back within 10 s of SIGCONT"
finish_load "a hung replica held a call over 8 s or cost a call"
echo "PASS: a replica hung for 12 s, no call waited over 8 s, no client saw an error"

# A 2 MB mesh: more than the HTTP/2 windows hold, so the refusal comes
# while the client still sends.
awk 'BEGIN { n = 200
  for (i = 0; i < n; i++) for (j = 0; j < n; j++) printf "v %d %d 0\n", i, j
  for (i = 0; i < n - 1; i++) for (j = 0; j < n - 1; j++) {
    a = i * n + j + 1; b = a + n
    printf "f %d %d %d\nf %d %d %d\n", a, b, a + 1, a + 1, b, b + 1 } }' \
  >"$tmp/grid.obj"
echo wrong-token >"$tmp/wrong"
for who in "no token" "unknown token"; do
  flags=()
  [ "$who" = "unknown token" ] && flags=(--token-file "$tmp/wrong")
  for i in $(seq 1 10); do
    MESHGAUGE_TOKEN= "$cli" remote --server "127.0.0.1:$hp" "${flags[@]}" \
      upload "$tmp/grid.obj" 2>&1 | tail -1 >>"$tmp/refused.txt" || true
  done
  n=$(grep -c "^meshgauge: error: UNAUTHENTICATED: " "$tmp/refused.txt" || true)
  [ "$n" -eq 10 ] || { cat "$tmp/refused.txt"; fail "uploads with $who: $n of 10 ended UNAUTHENTICATED"; }
  rm "$tmp/refused.txt"
done
echo "PASS: 20 uploads with no or an unknown token through the balancer, all UNAUTHENTICATED"

start_load 60 reload --retry=false
for c in 1 2 3; do
  await_progress "before reload $c"
  kill -USR2 "$haproxy_pid"
  echo "reload $c of the balancer"
done
await_progress "after the reloads"
finish_load "a reload of the balancer cost a client without retries a call"
echo "PASS: 3 reloads of the balancer, no client (without retries) saw an error"

# A restart: the old balancer soft-stops (SIGUSR1, its image's stop
# signal: no new connection, the calls in flight finish), then a new one
# starts on the same port. The clients do not retry; a call made in the gap
# waits for the connection (the client's connect timeout), none fails.
start_load 60 restart --retry=false
for c in 1 2; do
  await_progress "before restart $c"
  t0=$(date +%s.%N)
  kill -USR1 "$haproxy_pid"
  # Within the 30 s stop grace period `docker stop` gives it.
  for _ in $(seq 1 300); do kill -0 "$haproxy_pid" 2>/dev/null || break; sleep 0.1; done
  kill -0 "$haproxy_pid" 2>/dev/null && fail "the balancer's soft stop took over 30 s"
  wait "$haproxy_pid" || true
  keep=()
  for pid in "${pids[@]}"; do [ "$pid" = "$haproxy_pid" ] || keep+=("$pid"); done
  pids=("${keep[@]}")
  start_balancer
  echo "restart $c of the balancer: listening again $(since "$t0") s after SIGUSR1"
done
await_progress "after the restarts"
finish_load "a restart of the balancer cost a client without retries a call"
echo "PASS: 2 restarts (soft stop, start) of the balancer, no client (without retries) saw an error"

# Fan-out: `remote grad --fan-out 2` of four sessions (each a pass and a
# VJP in two parts): a session's two parts reach different replicas, and
# each part's VJP the replica that has its part's pass. The request lines of
# the balancer's log (level info here) name the replica and the captured
# x-meshgauge-part.
"$cli" shape sphere --out "$tmp/ball.obj" >/dev/null
for s in 1 2 3 4; do
  lines=$(wc -l <"$tmp/haproxy.log")
  "$cli" remote grad "$tmp/ball.obj" --rays 10 --fan-out 2 --session-id "fan-out-$s" \
    --server "127.0.0.1:$hp" --token-file "$tmp/token" >/dev/null ||
    fail "remote grad --fan-out 2 through the balancer failed"
  # "CALL PART REPLICA" per range call, e.g. "ComputeSdf 1 r0". The
  # balancer logs a call when its stream closes, which may come after the
  # client's reply: up to 10 s for 4 lines on a busy machine, then 0.5 s
  # more for any further one.
  range_calls() {
    tail -n +$((lines + 1)) "$tmp/haproxy.log" |
      sed -nE 's|.* meshgauge_parts/(r[01]) .*\{([0-9]+)\} "POST [^ ]*/meshgauge.v1.MeshGauge/(Compute[A-Za-z]+) .*|\3 \2 \1|p' \
      >"$tmp/parts"
  }
  for _ in $(seq 1 100); do
    range_calls
    [ "$(wc -l <"$tmp/parts")" -ge 4 ] && break
    sleep 0.1
  done
  sleep 0.5
  range_calls
  [ "$(wc -l <"$tmp/parts")" -eq 4 ] ||
    fail "session fan-out-$s: expected 4 range calls, the log has: $(cat "$tmp/parts")"
  for part in 0 1; do
    replicas=$(awk -v p="$part" '$2 == p { print $3 }' "$tmp/parts" | sort -u)
    [ "$(echo "$replicas" | wc -l)" -eq 1 ] ||
      fail "session fan-out-$s: part $part's pass and VJP went to different replicas: $(cat "$tmp/parts")"
  done
  [ "$(awk '{ print $3 }' "$tmp/parts" | sort -u | wc -l)" -eq 2 ] ||
    fail "session fan-out-$s: both parts went to one replica: $(cat "$tmp/parts")"
done
echo "PASS: 4 sessions' passes and VJPs fanned out in 2 parts: each session's parts on both replicas, each part's VJP where its pass was"

# The load's big-client mode through the balancer: one client whose passes,
# VJPs and penalties go out in 2 parts; every reply must be the single-call
# reference's, bit for bit.
"$load" --target "127.0.0.1:$hp" --clients 1 --iterations 4 --frequency 40 \
  --fan_out 2 --session_prefix big --time_limit_seconds 120 \
  --token_file "$tmp/token" >"$tmp/load.txt" 2>&1 ||
  fail "the big client (fan-out 2) saw an error or a reply unlike the reference's"
grep '^big client:' "$tmp/load.txt" || fail "the big client printed no speed-up"
echo "PASS: a big client fanned out over 2 replicas got the single-call replies, bit for bit"
