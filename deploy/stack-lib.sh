# The stack's settings and shell helpers, for deploy/stack.sh and the stack
# tests; source it after scripts/lib.sh. Every setting is an environment
# variable, defaulting to the operator's stack:
#   MESHGAUGE_PROJECT             compose project name (meshgauge): names the
#                                 containers, networks and volumes
#   MESHGAUGE_GRPC_PORT           127.0.0.1 port of the balancer (50051)
#   MESHGAUGE_PROMETHEUS_PORT     127.0.0.1 port of Prometheus (9090)
#   MESHGAUGE_ALERTMANAGER_PORT   127.0.0.1 port of Alertmanager (9093)
#   MESHGAUGE_SECRETS_DIR         the secrets (deploy/secrets)
#   MESHGAUGE_RUN_DIR             what stack.sh writes per run: the desired
#                                 replica count, Alertmanager's configuration
#                                 (deploy/.run)
#   MESHGAUGE_ALERT_WEBHOOK_URL   Alertmanager's receiver (a webhook;
#                                 default http://host.docker.internal:9095/meshgauge-alerts)
#   MESHGAUGE_CERT_NAMES          the server certificate's names
#                                 (deploy/make-secrets.sh)
# The stack tests set all of them to their own values, so that they never
# touch the operator's stack. Relative directories are taken from the
# directory the caller runs in.
MESHGAUGE_DEPLOY_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
export MESHGAUGE_PROJECT=${MESHGAUGE_PROJECT:-meshgauge}
export MESHGAUGE_GRPC_PORT=${MESHGAUGE_GRPC_PORT:-50051}
export MESHGAUGE_PROMETHEUS_PORT=${MESHGAUGE_PROMETHEUS_PORT:-9090}
export MESHGAUGE_ALERTMANAGER_PORT=${MESHGAUGE_ALERTMANAGER_PORT:-9093}
export MESHGAUGE_SECRETS_DIR
MESHGAUGE_SECRETS_DIR=$(realpath -m "${MESHGAUGE_SECRETS_DIR:-$MESHGAUGE_DEPLOY_DIR/secrets}")
export MESHGAUGE_RUN_DIR
MESHGAUGE_RUN_DIR=$(realpath -m "${MESHGAUGE_RUN_DIR:-$MESHGAUGE_DEPLOY_DIR/.run}")
export MESHGAUGE_ALERT_WEBHOOK_URL=${MESHGAUGE_ALERT_WEBHOOK_URL:-http://host.docker.internal:9095/meshgauge-alerts}

# The running containers of service $1 of this project, one id a line.
stack_containers() {
  docker ps -q --filter "label=com.docker.compose.project=$MESHGAUGE_PROJECT" \
    --filter "label=com.docker.compose.service=$1"
}

# The Nth running replica's container id.
stack_replica() {
  stack_containers meshgauge | sed -n "${1}p"
}

# Sends signal $2 (a name: HUP, USR2) to PID 1 of every running container of
# service $1, from inside the container (`docker exec ... kill`). Not
# `docker kill -s`/`docker-compose kill -s`: on Docker 20.10 those mark the
# container as stopped by hand, so that its restart policy unless-stopped no
# longer restarts it when it later dies (moby issues 41302, 47792).
stack_signal() {
  local c
  for c in $(stack_containers "$1"); do
    docker exec "$c" sh -c "kill -s $2 1"
  done
}

# Runs the meshgauge image's program $1 with arguments $2... on the host
# network as the caller's user, with the stack's secrets at /secrets and
# MESHGAUGE_TOKEN passed on when set; the container is named
# $STACK_TOOL_NAME when set (to signal it).
stack_tool() {
  docker run --rm --no-healthcheck --network host --user "$(id -u):$(id -g)" \
    ${STACK_TOOL_NAME:+--name "$STACK_TOOL_NAME"} \
    -v "$MESHGAUGE_SECRETS_DIR:/secrets:ro" ${MESHGAUGE_TOKEN:+-e MESHGAUGE_TOKEN} \
    --entrypoint "$1" "meshgauge:$(meshgauge_version)" "${@:2}"
}

# Succeeds when a ListSessions call through the stack's balancer with token
# $1 passes.
stack_accepts_token() {
  MESHGAUGE_TOKEN="$1" stack_tool meshgauge remote list \
    --server "127.0.0.1:$MESHGAUGE_GRPC_PORT" --tls-ca-file /secrets/ca.crt \
    >/dev/null 2>&1
}

# The newest image of the stack's build stage (label meshgauge.stage=build:
# the cache of the next `deploy/stack.sh up`), empty when there is none.
stack_build_stage() {
  docker images -q --filter label=meshgauge.stage=build | head -1
}
