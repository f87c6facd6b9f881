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
