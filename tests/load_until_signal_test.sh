#!/usr/bin/env bash
# meshgauge-load --until_signal against one local server: the clients go on
# past the reference's iterations (positions cycling through them, each reply
# still bit-identical to the reference's at the same positions: SPEC §3,
# v2.1)
# until SIGTERM, then end their iteration, check their sessions and pass.
# Usage: load_until_signal_test.sh SERVER LOAD
set -euo pipefail
server=$1 load=$2
tmp=$(mktemp -d)
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$tmp"; }
trap cleanup EXIT
source "$(dirname "$0")/../scripts/lib.sh"
fail() { echo "--- load client"; cat "$tmp/load.txt"; echo "FAIL: $*"; exit 1; }

"$server" --address 127.0.0.1:0 --metrics_address= --port_file "$tmp/port" \
  2>"$tmp/server.log" &
pids+=($!)
port=$(await_port_file "$tmp/port")

# 3 clients x 3 reference iterations: 30 iterations in all means every client
# went round the positions several times (at most one client can stop early:
# it would print an error).
"$load" --target "127.0.0.1:$port" --clients 3 --iterations 3 --frequency 4 \
  --until_signal --time_limit_seconds 120 --progress_every 3 \
  >"$tmp/load.txt" 2>&1 &
load_pid=$!
pids+=($load_pid)
await_lines "$tmp/load.txt" '^iterations:' 9 1200 ||
  fail "the clients did not go past the reference's iterations"
kill -0 "$load_pid" 2>/dev/null || fail "the load ended before the signal"
kill -TERM "$load_pid"
rc=0
wait "$load_pid" || rc=$?
grep -v '^iterations:' "$tmp/load.txt"
[ "$rc" -eq 0 ] || fail "exit status $rc after SIGTERM"
grep -q "until signalled" "$tmp/load.txt" || fail "not in --until_signal mode"
grep -q "^errors: 0" "$tmp/load.txt" || fail "errors"
grep -q " 3/3 clients finished" "$tmp/load.txt" || fail "a client did not finish"
grep -q "against the single-client reference: 0" "$tmp/load.txt" ||
  fail "replies differ from the reference at the same positions"
grep -q "sessions lost: 0" "$tmp/load.txt" || fail "sessions lost"
echo "PASS"
