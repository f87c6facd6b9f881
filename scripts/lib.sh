# Shell helpers of the repository's scripts and shell tests; source it.
# Servers are started on port 0 with --port_file (await_port_file reads the
# port back); free_port is for programs that cannot report the port they
# bound (Redis, HAProxy).

# A free loopback TCP port.
free_port() {
  /usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'
}

# Waits up to $2 tenths of a second (default 200) for the --port_file $1
# and prints the port; fails when it does not come.
await_port_file() {
  for _ in $(seq 1 "${2:-200}"); do
    [ -s "$1" ] && { cat "$1"; return 0; }
    sleep 0.1
  done
  echo "no port in $1" >&2
  return 1
}

# Waits up to $2 tenths of a second (default 200) until 127.0.0.1:$1
# accepts connections.
await_tcp() {
  for _ in $(seq 1 "${2:-200}"); do
    (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null && return 0
    sleep 0.1
  done
  echo "nothing listens on 127.0.0.1:$1" >&2
  return 1
}

# A throwaway redis-server on a free loopback port, its data and log in
# directory $1 (append-only file when $2 is "yes"): sets redis_port, adds
# its pid to the caller's array `pids` (to kill on exit), and waits until it
# accepts connections.
start_redis() {
  redis_port=$(free_port)
  redis-server --port "$redis_port" --bind 127.0.0.1 --save "" \
    --appendonly "${2:-no}" --dir "$1" --logfile "$1/redis.log" &
  pids+=($!)
  await_tcp "$redis_port"
}

# Waits up to $4 tenths of a second for file $1 to hold more than $3 lines
# matching the extended regular expression $2.
await_lines() {
  for _ in $(seq 1 "$4"); do
    [ "$(grep -cE "$2" "$1" 2>/dev/null)" -gt "$3" ] && return 0
    sleep 0.1
  done
  return 1
}

# The first value of the instant PromQL query $2 on the Prometheus at URL $1
# (empty when the result is empty or Prometheus cannot be reached).
prom_query() {
  curl -sf "$1/api/v1/query" --data-urlencode "query=$2" |
    grep -o '"value":\[[^]]*\]' | head -1 | grep -o '"[0-9.e+-]*"\]' |
    tr -d '"]' || true
}

# Waits up to $3 tenths of a second until the query $2 on the Prometheus at
# URL $1 has a result (a PromQL comparison filters it to none until true).
await_prom() {
  for _ in $(seq 1 "$3"); do
    [ -n "$(prom_query "$1" "$2")" ] && return 0
    sleep 0.1
  done
  return 1
}

# The release (the one line of VERSION at the repository's root).
meshgauge_version() {
  head -1 "$(dirname "${BASH_SOURCE[0]}")/../VERSION"
}
