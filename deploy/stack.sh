#!/usr/bin/env bash
# The operator's commands for the meshgauge stack (docs/deployment.md):
#   deploy/stack.sh up [REPLICAS]   check that ports 50051 and 9090 are free
#                                   (before anything starts), build the
#                                   images, start everything with REPLICAS
#                                   replicas (default 2), wait until the
#                                   balancer serves
#   deploy/stack.sh scale N         N replicas; the balancer and Prometheus
#                                   find them by DNS, sessions stay in Redis
#   deploy/stack.sh rotate-secrets [--finish]  a new server certificate (same
#                                   CA) served after a balancer reload, and a
#                                   new token accepted beside the old one;
#                                   --finish, once the clients use the new
#                                   token: the old one is refused
#   deploy/stack.sh backup-redis FILE   Redis's data (append-only file) into
#                                   the tarball FILE while it runs
#   deploy/stack.sh restore-redis FILE  stop Redis, replace its data with
#                                   FILE's, start it
#   deploy/stack.sh reload-balancer  re-read the balancer's configuration and
#                                   certificate (SIGUSR2: a new HAProxy
#                                   worker; calls in flight finish)
#   deploy/stack.sh down [--volumes] [--prune]  stop and remove the
#                                   containers (--volumes: and the Redis and
#                                   Prometheus data; --prune: and the build
#                                   stage's image, the cache of the next
#                                   `up`'s compile)
#   deploy/stack.sh swarm-up [REPLICAS] | swarm-down [--leave]   the same
#                                   services as a Swarm stack (deploy/stack.yml;
#                                   swarm-up makes this node a one-node swarm
#                                   if it is none; --leave undoes that)
# gRPC on 127.0.0.1:50051 (TLS, token: deploy/secrets), Prometheus on
# 127.0.0.1:9090.
set -euo pipefail
if [ -n "${MESHGAUGE_PREBUILT_FROM:-}" ]; then
  MESHGAUGE_PREBUILT_FROM=$(realpath "$MESHGAUGE_PREBUILT_FROM")
fi
cd "$(dirname "$0")"
source ../scripts/lib.sh
VERSION=$(meshgauge_version)
export MESHGAUGE_VERSION="$VERSION"
COMPOSE="docker-compose -p meshgauge -f docker-compose.yml"

# Waits until a health call through the balancer answers SERVING.
wait_serving() {
  for _ in $(seq 1 90); do
    if stack_tool meshgauge remote health --server 127.0.0.1:50051 \
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
  cert_before=$(cat secrets/server.crt 2>/dev/null || true)
  ./make-secrets.sh
  # A renewed certificate is served after a reload of a running balancer.
  [ "$(cat secrets/server.crt)" = "$cert_before" ] || RELOAD_BALANCER=1
  rm -rf .prebuilt
  export MESHGAUGE_PREBUILT=
  if [ -n "${MESHGAUGE_PREBUILT_FROM:-}" ]; then
    mkdir .prebuilt
    cp "$MESHGAUGE_PREBUILT_FROM"/server/meshgauge-server \
       "$MESHGAUGE_PREBUILT_FROM"/client/meshgauge \
       "$MESHGAUGE_PREBUILT_FROM"/bench/meshgauge-load .prebuilt/
    export MESHGAUGE_PREBUILT=deploy/.prebuilt
  fi
  $COMPOSE build
}

# The multi-stage build's compiler stage: the build cache of the next `up`.
prune_build_stage() {
  docker image prune -f --filter label=meshgauge.stage=build >/dev/null
}

# Fails, naming them, when 127.0.0.1's ports 50051 and 9090 are taken by
# anything but this stack (checked before anything is built or started).
check_ports() {
  [ -n "$(docker service ls -q --filter name=meshgauge_balancer 2>/dev/null)" ] &&
    return 0
  local taken=()
  for port in 50051 9090; do
    # A port a running container of this stack publishes is the stack's own
    # (a stopped one left behind holds nothing, and proves nothing).
    [ -n "$(docker ps -q --filter label=com.docker.compose.project=meshgauge \
              --filter "publish=$port" 2>/dev/null)" ] && continue
    (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null && taken+=("$port")
  done
  [ ${#taken[@]} -eq 0 ] && return 0
  echo "stack: 127.0.0.1 port(s) ${taken[*]} already in use; free them first (nothing was started)" >&2
  return 1
}

# The operator's desired replica count, for the alert
# MeshgaugeReplicasBelowDesired: a rule file in .desired/ (mounted into
# Prometheus), re-read by a running Prometheus on SIGHUP.
set_desired() {  # N
  mkdir -p .desired
  cat >.desired/replicas.yml <<RULES
# Written by deploy/stack.sh: the stack's desired replica count.
groups:
  - name: meshgauge-desired
    rules:
      - record: meshgauge:replicas_desired
        expr: vector($1)
RULES
  local p
  for p in $(docker ps -q --filter label=com.docker.compose.project=meshgauge \
               --filter label=com.docker.compose.service=prometheus) \
           $(docker ps -q --filter label=com.docker.swarm.service.name=meshgauge_prometheus); do
    docker kill -s HUP "$p" >/dev/null
  done
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
  for c in $($COMPOSE ps -q meshgauge); do
    seen[$c]=$(docker logs "$c" 2>&1 | grep -c 'SIGHUP:' || true)
  done
  $COMPOSE kill -s SIGHUP meshgauge 2>/dev/null
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
    $COMPOSE up -d --scale meshgauge="${2:-2}"
    if [ "$RELOAD_BALANCER" = 1 ]; then
      $COMPOSE kill -s SIGUSR2 balancer 2>/dev/null
    fi
    wait_serving
    echo "stack: up, ${2:-2} replicas, gRPC 127.0.0.1:50051, Prometheus 127.0.0.1:9090"
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
      docker run --rm --network none --user "$(id -u):$(id -g)" \
        -v meshgauge_redis-data:/data:ro -v "$dir:/backup" \
        --entrypoint tar "meshgauge-redis:$VERSION" czf "/backup/$file" -C /data .
    else
      [ -f "$2" ] || { echo "stack: no file $2" >&2; exit 1; }
      $COMPOSE stop redis 2>/dev/null
      docker run --rm --network none --user 0 -v meshgauge_redis-data:/data \
        -v "$dir:/backup:ro" --entrypoint sh "meshgauge-redis:$VERSION" -c \
        "find /data -mindepth 1 -delete && tar xzf '/backup/$file' -C /data && chown -R redis:redis /data"
      $COMPOSE start redis 2>/dev/null
    fi
    ;;
  reload-balancer)
    $COMPOSE kill -s SIGUSR2 balancer 2>/dev/null
    ;;
  rotate-secrets)
    if [ -n "$(docker service ls -q --filter name=meshgauge_balancer 2>/dev/null)" ]; then
      echo "stack: the Swarm stack's secrets are Swarm secrets; rotate them with docker service update (docs/deployment.md)" >&2
      exit 1
    fi
    if [ "${2:-}" = --finish ]; then
      ./make-secrets.sh finish
      reload_replicas_tokens || exit 1
      echo "stack: only the token in deploy/secrets/token is accepted now"
    else
      # The new token is published only once every replica re-read the
      # tokens file and it passes through the balancer.
      ./make-secrets.sh rotate
      reload_replicas_tokens || exit 1
      $COMPOSE kill -s SIGUSR2 balancer 2>/dev/null
      token_accepted "$(cat secrets/token.next)" || {
        echo "stack: the new token is refused; the old token stays in use" >&2
        exit 1
      }
      ./make-secrets.sh publish
      echo "stack: new certificate served; deploy/secrets/token is new and the old token still works. Move the clients to it, then: deploy/stack.sh rotate-secrets --finish"
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
    if [ "$prune" = 1 ]; then prune_build_stage; fi
    ;;
  swarm-up)
    check_ports
    build
    set_desired "${2:-2}"
    docker info --format '{{.Swarm.LocalNodeState}}' | grep -qx active ||
      docker swarm init --advertise-addr 127.0.0.1 >/dev/null
    REPLICAS="${2:-2}" docker stack deploy -c stack.yml meshgauge
    wait_serving
    echo "stack: swarm stack up, gRPC 127.0.0.1:50051"
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
