#!/usr/bin/env bash
# The operator's commands for the meshgauge stack (docs/deployment.md):
#   deploy/stack.sh up [REPLICAS]   check that its ports (50051, 9090, 9093)
#                                   are free (before anything starts), build
#                                   the images (cached: nothing is rebuilt
#                                   when nothing changed), start everything
#                                   with REPLICAS replicas (default 2), wait
#                                   until the balancer serves
#   deploy/stack.sh scale N         N replicas; the balancer and Prometheus
#                                   find them by DNS, sessions stay in Redis
#   deploy/stack.sh rotate-secrets [--finish]  a new server certificate (same
#                                   CA) served after a balancer reload, and a
#                                   new token accepted beside the old one;
#                                   --finish, once the clients use the new
#                                   token: the old one is refused
#   deploy/stack.sh backup-redis FILE   a snapshot of Redis (BGSAVE, once it
#                                   finished) into the tarball FILE while it
#                                   runs and is written
#   deploy/stack.sh restore-redis FILE  replace Redis' data with FILE's:
#                                   replicated into the running Redis (writes
#                                   refused for under a second), or with it
#                                   stopped when it does not answer (sessions
#                                   roll back either way)
#   deploy/stack.sh reload-balancer  re-read the balancer's configuration and
#                                   certificate (SIGUSR2: a new HAProxy
#                                   worker; calls in flight finish)
#   deploy/stack.sh down [--volumes] [--prune]  stop and remove the
#                                   containers and the stack's dangling
#                                   images (--volumes: and the Redis,
#                                   Prometheus and Alertmanager data;
#                                   --prune: and the build stage's image,
#                                   the cache of the next `up`'s compile)
#   deploy/stack.sh swarm-up [REPLICAS] | swarm-down [--leave]   the same
#                                   services as a Swarm stack (deploy/stack.yml;
#                                   swarm-up makes this node a one-node swarm
#                                   if it is none; --leave undoes that)
# Settings (project name, ports, secrets and run directories, the alert
# webhook): environment variables, deploy/stack-lib.sh. Signals go to the
# containers' processes through `docker exec`, never `docker kill -s`, which
# would disable their restart policy on Docker 20.10.
set -euo pipefail
if [ -n "${MESHGAUGE_PREBUILT_FROM:-}" ]; then
  MESHGAUGE_PREBUILT_FROM=$(realpath "$MESHGAUGE_PREBUILT_FROM")
fi
# Relative directories in the settings are the caller's.
for v in MESHGAUGE_SECRETS_DIR MESHGAUGE_RUN_DIR; do
  [ -z "${!v:-}" ] || export "$v=$(realpath -m "${!v}")"
done
cd "$(dirname "$0")"
source ../scripts/lib.sh
source stack-lib.sh
VERSION=$(meshgauge_version)
export MESHGAUGE_VERSION="$VERSION"
COMPOSE="docker-compose -p $MESHGAUGE_PROJECT -f docker-compose.yml"
FRONT=127.0.0.1:$MESHGAUGE_GRPC_PORT

# Waits until a health call through the balancer answers SERVING.
wait_serving() {
  for _ in $(seq 1 90); do
    if stack_tool meshgauge remote health --server "$FRONT" \
         --tls-ca-file /secrets/ca.crt >/dev/null 2>&1; then
      return 0
    fi
    sleep 1
  done
  echo "stack: the balancer did not serve within 90 s" >&2
  return 1
}

# MESHGAUGE_PREBUILT_FROM=DIR (a Debian 12 build directory, as CI's): the
# image takes DIR's binaries instead of compiling them.
build() {
  ./make-base-image.sh
  local cert_before
  cert_before=$(cat "$MESHGAUGE_SECRETS_DIR/server.crt" 2>/dev/null || true)
  ./make-secrets.sh
  # A renewed certificate is served after a reload of a running balancer.
  [ "$(cat "$MESHGAUGE_SECRETS_DIR/server.crt")" = "$cert_before" ] || RELOAD_BALANCER=1
  export MESHGAUGE_PREBUILT=
  if [ -n "${MESHGAUGE_PREBUILT_FROM:-}" ]; then
    # Replaced only when they changed (the build cache compares contents).
    mkdir -p .prebuilt
    local f
    for f in server/meshgauge-server client/meshgauge client/meshgauge-remote \
        bench/meshgauge-load; do
      cmp -s "$MESHGAUGE_PREBUILT_FROM/$f" ".prebuilt/${f#*/}" ||
        cp "$MESHGAUGE_PREBUILT_FROM/$f" .prebuilt/
    done
    export MESHGAUGE_PREBUILT=deploy/.prebuilt
  else
    rm -rf .prebuilt
  fi
  $COMPOSE build
}

# The multi-stage build's compiler stage: the build cache of the next `up`.
prune_build_stage() {
  docker image prune -f --filter label=meshgauge.stage=build >/dev/null
}

# The stack's dangling images (an image a rebuild replaced, no container
# uses), and every build stage but the newest (the next build's cache).
prune_dangling() {
  local title
  for title in meshgauge meshgauge-redis meshgauge-balancer meshgauge-prometheus; do
    docker image prune -f --filter "label=org.opencontainers.image.title=$title" >/dev/null
  done
  docker images -q --filter label=meshgauge.stage=build | sed 1d |
    xargs -r docker rmi >/dev/null 2>&1 || true
}

# Fails, naming them, when 127.0.0.1's ports of the stack are taken by
# anything but this stack (checked before anything is built or started).
check_ports() {
  [ "$MESHGAUGE_PROJECT" = meshgauge ] &&
    [ -n "$(docker service ls -q --filter name=meshgauge_balancer 2>/dev/null)" ] &&
    return 0
  local taken=()
  for port in "$MESHGAUGE_GRPC_PORT" "$MESHGAUGE_PROMETHEUS_PORT" "$MESHGAUGE_ALERTMANAGER_PORT"; do
    # A port a running container of this stack publishes is the stack's own
    # (a stopped one left behind holds nothing, and proves nothing).
    [ -n "$(docker ps -q --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
              --filter "publish=$port" 2>/dev/null)" ] && continue
    (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null && taken+=("$port")
  done
  [ ${#taken[@]} -eq 0 ] && return 0
  echo "stack: 127.0.0.1 port(s) ${taken[*]} already in use; free them first (nothing was started)" >&2
  return 1
}

# The run directory (mounted read-only into Prometheus and Alertmanager):
# rules/replicas.yml, the operator's desired replica count, for the alert
# MeshgaugeReplicasBelowDesired; alertmanager/alertmanager.yml, the
# receiver. A running Prometheus and Alertmanager re-read them on SIGHUP.
run_dir() {
  mkdir -p "$MESHGAUGE_RUN_DIR/rules" "$MESHGAUGE_RUN_DIR/alertmanager"
  chmod 0755 "$MESHGAUGE_RUN_DIR" "$MESHGAUGE_RUN_DIR/rules" "$MESHGAUGE_RUN_DIR/alertmanager"
}

set_desired() {  # N
  run_dir
  cat >"$MESHGAUGE_RUN_DIR/rules/replicas.yml" <<RULES
# Written by deploy/stack.sh: the stack's desired replica count.
groups:
  - name: meshgauge-desired
    rules:
      - record: meshgauge:replicas_desired
        expr: vector($1)
RULES
  chmod 0644 "$MESHGAUGE_RUN_DIR/rules/replicas.yml"
  # A Prometheus restarting now reads the file when it starts.
  stack_signal prometheus HUP || true
  if [ "$MESHGAUGE_PROJECT" = meshgauge ]; then  # the Swarm stack's
    local p
    for p in $(docker ps -q --filter label=com.docker.swarm.service.name=meshgauge_prometheus); do
      docker exec "$p" sh -c 'kill -s HUP 1' || true
    done
  fi
}

# Alertmanager's configuration: prometheus/alertmanager.yml with the
# webhook MESHGAUGE_ALERT_WEBHOOK_URL; a running Alertmanager re-reads it.
set_receiver() {
  run_dir
  local f=$MESHGAUGE_RUN_DIR/alertmanager/alertmanager.yml
  sed "s|^\( *- url: \).*|\1\"$MESHGAUGE_ALERT_WEBHOOK_URL\"|" \
    prometheus/alertmanager.yml >"$f.new"
  chmod 0644 "$f.new"
  if cmp -s "$f.new" "$f"; then rm "$f.new"; return 0; fi
  mv -f "$f.new" "$f"
  stack_signal alertmanager HUP || true
}

# Succeeds when a ListSessions call with token $1 passes (waits up to 10 s).
token_accepted() {
  for _ in $(seq 1 20); do
    stack_accepts_token "$1" && return 0
    sleep 0.5
  done
  return 1
}

# SIGHUP to every replica; waits until each logs that it re-read its tokens
# file (fails naming one that kept its tokens or did not answer in 10 s).
reload_replicas_tokens() {
  local c n
  declare -A seen
  for c in $(stack_containers meshgauge); do
    seen[$c]=$(docker logs "$c" 2>&1 | grep -c 'SIGHUP:' || true)
  done
  stack_signal meshgauge HUP
  for c in "${!seen[@]}"; do
    for _ in $(seq 1 50); do
      n=$(docker logs "$c" 2>&1 | grep -c 'SIGHUP:' || true)
      [ "$n" -gt "${seen[$c]}" ] && break
      sleep 0.2
    done
    docker logs "$c" 2>&1 | grep 'SIGHUP:' | tail -1 | grep -q 're-read' || {
      echo "stack: replica $c did not re-read its tokens file:" >&2
      docker logs "$c" 2>&1 | grep 'SIGHUP:' | tail -1 >&2
      return 1
    }
  done
}

# The running Redis container (fails when there is none).
redis_container() {
  local r
  r=$(stack_containers redis | head -1)
  [ -n "$r" ] || { echo "stack: Redis is not running (deploy/stack.sh up)" >&2; return 1; }
  echo "$r"
}

# A snapshot of Redis while it runs and is written: BGSAVE (a forked child
# writes a point-in-time dump.rdb, renamed into place when complete), wait
# until it finished (LASTSAVE moves, no save in progress, status ok), check
# it, copy it out. The append-only file is not copied: it changes while it
# is read.
backup_redis() {  # DIR FILE
  local r before now info
  r=$(redis_container)
  before=$(docker exec "$r" redis-cli LASTSAVE)
  # LASTSAVE counts seconds: a save that ended this second would hide ours.
  now=$(docker exec "$r" redis-cli TIME | head -1)
  [ "$now" -gt "$before" ] || sleep 1
  docker exec "$r" redis-cli BGSAVE SCHEDULE >/dev/null
  for _ in $(seq 1 3000); do  # up to 10 min
    info=$(docker exec "$r" redis-cli INFO persistence | tr -d '\r')
    if [ "$(docker exec "$r" redis-cli LASTSAVE)" -gt "$before" ] &&
       grep -qx 'rdb_bgsave_in_progress:0' <<<"$info"; then
      break
    fi
    sleep 0.2
  done
  grep -qx 'rdb_last_bgsave_status:ok' <<<"$info" &&
    [ "$(docker exec "$r" redis-cli LASTSAVE)" -gt "$before" ] || {
    echo "stack: Redis' BGSAVE did not finish (INFO persistence below); no backup written" >&2
    grep -E '^rdb_|^aof_rewrite_in' <<<"$info" >&2
    return 1
  }
  docker exec "$r" redis-check-rdb /data/dump.rdb >/dev/null || {
    echo "stack: the snapshot fails redis-check-rdb; no backup written" >&2; return 1; }
  local tmp
  tmp=$(mktemp -d)
  docker exec "$r" cat /data/dump.rdb >"$tmp/dump.rdb"
  tar czf "$1/.$2.new" -C "$tmp" dump.rdb
  rm -rf "$tmp"
  mv -f "$1/.$2.new" "$1/$2"
  echo "stack: backup $1/$2 ($(stat -c %s "$1/$2") bytes, a snapshot of $(date -u -d "@$(docker exec "$r" redis-cli LASTSAVE)" +%FT%TZ))"
}

# Restores the archive FILE of backup_redis into the running Redis without
# stopping it: a temporary Redis on the stack's private network loads the
# snapshot, the stack's Redis replicates it (REPLICAOF: it drops its data
# and loads the snapshot's; meanwhile it refuses writes, READONLY, which the
# replicas answer UNAVAILABLE and clients retry), then is master again
# (REPLICAOF NO ONE) and rewrites its append-only file from the restored
# data. Writes are refused for well under a second here; reads never stop.
restore_online() {  # DIR FILE REDIS_CONTAINER
  local r=$3 net tmp=$MESHGAUGE_PROJECT-redis-restore vol keys ok t0 t1
  net=$(docker inspect -f '{{range $k, $v := .NetworkSettings.Networks}}{{$k}} {{end}}' "$r" | awk '{print $1}')
  docker rm -f "$tmp" >/dev/null 2>&1 || true
  vol=$(docker volume create)
  # shellcheck disable=SC2064
  trap "trap - RETURN; docker rm -f '$tmp' >/dev/null 2>&1 || true; docker volume rm '$vol' >/dev/null 2>&1 || true" RETURN
  docker run --rm --network none --user 0 -v "$vol:/data" -v "$1:/backup:ro" \
    --entrypoint sh "meshgauge-redis:$VERSION" -c \
    "tar xzf '/backup/$2' -C /data dump.rdb && chown -R redis:redis /data"
  docker run -d --name "$tmp" --network "$net" --read-only --tmpfs /tmp \
    --cap-drop ALL -v "$vol:/data" "meshgauge-redis:$VERSION" redis-server \
    --bind 0.0.0.0 --protected-mode no --dir /data --appendonly no --save "" \
    --repl-diskless-sync-delay 0 >/dev/null
  for _ in $(seq 1 3000); do
    [ "$(docker exec "$tmp" redis-cli PING 2>/dev/null)" = PONG ] && break
    sleep 0.2
  done
  keys=$(docker exec "$tmp" redis-cli DBSIZE) ||
    { echo "stack: the snapshot did not load (docker logs $tmp)" >&2; return 1; }
  # One shell in the container: the switch back comes within 20 ms of the
  # load's end (a docker exec per poll would add a few tenths each).
  local out
  out=$(docker exec "$r" sh -c "
    t0=\$(date +%s.%N)
    redis-cli REPLICAOF $tmp 6379 >/dev/null
    n=0 ok=0
    while [ \$n -lt 30000 ]; do  # up to 10 min for a large snapshot
      i=\$(redis-cli INFO replication; redis-cli INFO persistence)
      case \"\$i\" in *master_link_status:up*)
        case \"\$i\" in *master_sync_in_progress:0*)
          case \"\$i\" in *loading:0*) ok=1; break ;; esac ;; esac ;; esac
      sleep 0.02
      n=\$((n + 1))
    done
    redis-cli REPLICAOF NO ONE >/dev/null
    echo \$ok \$(date +%s.%N) \$t0")
  read -r ok t1 t0 <<<"$out"
  [ "$ok" = 1 ] || {
    echo "stack: Redis did not replicate the snapshot; it is master again with its own data" >&2
    return 1; }
  echo "stack: restored $1/$2 ($keys keys) into the running Redis; writes were refused for $(awk "BEGIN {printf \"%.2f\", $t1 - $t0}") s"
}

# Stops Redis, replaces its data with the archive's, starts it, waits until
# it answers: for a Redis that does not run or answer, or an archive of an
# earlier release (an appendonlydir). A dump.rdb becomes the base of a new
# append-only file (Redis 7 with appendonly yes ignores a dump.rdb alone).
# Calls fail UNAVAILABLE meanwhile (several seconds).
restore_offline() {  # DIR FILE
  local r volume start=$SECONDS
  r=$(docker ps -aq --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
        --filter label=com.docker.compose.service=redis | head -1)
  [ -n "$r" ] || { echo "stack: no Redis container (deploy/stack.sh up)" >&2; return 1; }
  volume=$(docker inspect -f '{{range .Mounts}}{{if eq .Destination "/data"}}{{.Name}}{{end}}{{end}}' "$r")
  # Plain docker commands: docker-compose's each cost a second more of
  # outage. A stop (not a kill) keeps the restart policy.
  docker stop -t 10 "$r" >/dev/null
  docker run --rm --network none --user 0 -v "$volume:/data" -v "$1:/backup:ro" \
    --entrypoint sh "meshgauge-redis:$VERSION" -c "
      set -e
      find /data -mindepth 1 -delete
      tar xzf '/backup/$2' -C /data
      if [ -f /data/dump.rdb ]; then
        mkdir -p /data/appendonlydir
        mv /data/dump.rdb /data/appendonlydir/appendonly.aof.1.base.rdb
        echo 'file appendonly.aof.1.base.rdb seq 1 type b' >/data/appendonlydir/appendonly.aof.manifest
      fi
      chown -R redis:redis /data"
  docker start "$r" >/dev/null
  for _ in $(seq 1 600); do
    [ "$(docker exec "$r" redis-cli PING 2>/dev/null)" = PONG ] && break
    sleep 0.1
  done
  [ "$(docker exec "$r" redis-cli PING 2>/dev/null)" = PONG ] ||
    { echo "stack: Redis did not come back after the restore" >&2; return 1; }
  echo "stack: restored $1/$2 with Redis stopped; it answered again $((SECONDS - start)) s after it stopped"
}

restore_redis() {  # DIR FILE
  local r
  r=$(stack_containers redis | head -1)
  if [ -n "$r" ] && [ "$(docker exec "$r" redis-cli PING 2>/dev/null)" = PONG ] &&
     tar tzf "$1/$2" | grep -qx 'dump.rdb'; then
    restore_online "$1" "$2" "$r"
  else
    restore_offline "$1" "$2"
  fi
}

count_or_die() {  # the argument must be a replica count
  [[ "${1:-}" =~ ^[0-9]+$ ]] || { echo "stack: '${1:-}' is not a replica count" >&2; exit 2; }
}

case "${1:-}" in
  up)
    count_or_die "${2:-2}"
    check_ports
    RELOAD_BALANCER=0
    build
    set_desired "${2:-2}"
    set_receiver
    $COMPOSE up -d --scale meshgauge="${2:-2}"
    if [ "$RELOAD_BALANCER" = 1 ]; then
      stack_signal balancer USR2
    fi
    wait_serving
    echo "stack: up (project $MESHGAUGE_PROJECT), ${2:-2} replicas, gRPC $FRONT, Prometheus 127.0.0.1:$MESHGAUGE_PROMETHEUS_PORT, Alertmanager 127.0.0.1:$MESHGAUGE_ALERTMANAGER_PORT"
    ;;
  scale)
    count_or_die "${2:-}"
    set_desired "$2"
    $COMPOSE up -d --no-recreate --scale meshgauge="$2" meshgauge
    ;;
  backup-redis | restore-redis)
    [ -n "${2:-}" ] || { echo "usage: stack.sh $1 FILE" >&2; exit 2; }
    dir=$(realpath "$(dirname "$2")") file=$(basename "$2")
    if [ "$1" = backup-redis ]; then
      backup_redis "$dir" "$file"
    else
      [ -f "$2" ] || { echo "stack: no file $2" >&2; exit 1; }
      restore_redis "$dir" "$file"
    fi
    ;;
  reload-balancer)
    stack_signal balancer USR2
    ;;
  rotate-secrets)
    if [ "$MESHGAUGE_PROJECT" = meshgauge ] &&
       [ -n "$(docker service ls -q --filter name=meshgauge_balancer 2>/dev/null)" ]; then
      echo "stack: the Swarm stack's secrets are Swarm secrets; rotate them with docker service update (docs/deployment.md)" >&2
      exit 1
    fi
    if [ "${2:-}" = --finish ]; then
      ./make-secrets.sh finish
      reload_replicas_tokens || exit 1
      echo "stack: only the token in $MESHGAUGE_SECRETS_DIR/token is accepted now"
    else
      # The new token is published only once every replica re-read the
      # tokens file and it passes through the balancer.
      ./make-secrets.sh rotate
      reload_replicas_tokens || exit 1
      stack_signal balancer USR2
      token_accepted "$(cat "$MESHGAUGE_SECRETS_DIR/token.next")" || {
        echo "stack: the new token is refused; the old token stays in use" >&2
        exit 1
      }
      ./make-secrets.sh publish
      echo "stack: new certificate served; $MESHGAUGE_SECRETS_DIR/token is new and the old token still works. Move the clients to it, then: deploy/stack.sh rotate-secrets --finish"
    fi
    ;;
  down)
    volumes=() prune=0
    for a in "${@:2}"; do
      case "$a" in
        --volumes) volumes=(-v) ;;
        --prune) prune=1 ;;
        *) echo "usage: stack.sh down [--volumes] [--prune]" >&2; exit 2 ;;
      esac
    done
    $COMPOSE down "${volumes[@]}" --remove-orphans
    prune_dangling
    if [ "$prune" = 1 ]; then prune_build_stage; fi
    ;;
  swarm-up)
    [ "$MESHGAUGE_PROJECT" = meshgauge ] ||
      { echo "stack: the Swarm stack is the project meshgauge only" >&2; exit 2; }
    check_ports
    build
    set_desired "${2:-2}"
    set_receiver
    docker info --format '{{.Swarm.LocalNodeState}}' | grep -qx active ||
      docker swarm init --advertise-addr 127.0.0.1 >/dev/null
    REPLICAS="${2:-2}" docker stack deploy -c stack.yml meshgauge
    wait_serving
    echo "stack: swarm stack up, gRPC $FRONT"
    ;;
  swarm-down)
    docker stack rm meshgauge
    if [ "${2:-}" = "--leave" ]; then docker swarm leave --force; fi
    ;;
  *)
    echo "usage: stack.sh up [REPLICAS] | scale N | rotate-secrets [--finish] | backup-redis FILE | restore-redis FILE | reload-balancer | down [--volumes] [--prune] | swarm-up [REPLICAS] | swarm-down [--leave]" >&2
    exit 2
    ;;
esac
