#!/usr/bin/env bash
# --help of the absl-flag programs (server/flags_help.h): it printed "No
# flags matched." and exited 1. Now each lists its own flags with their
# defaults and exits 0; --helpshort and --helppackage list them too, and
# --version still answers.
# Usage: flags_help_test.sh SERVER LOAD
set -uo pipefail
server=$1 load=$2
fail=0
check() {  # check NAME OUTPUT EXPECTED...
  local name=$1 out=$2; shift 2
  for want in "$@"; do
    if ! grep -qF -- "$want" <<<"$out"; then
      echo "FAIL: $name: no '$want' in:"; echo "$out" | head -20; fail=1
    fi
  done
  if grep -qF "No flags matched" <<<"$out"; then
    echo "FAIL: $name: 'No flags matched.'"; fail=1
  fi
}
for arg in --help -help --helpshort; do
  out=$("$server" "$arg" 2>&1); rc=$?
  [ "$rc" -eq 0 ] || { echo "FAIL: meshgauge-server $arg exited $rc"; fail=1; }
  check "meshgauge-server $arg" "$out" "meshgauge-server [flags]" \
    '--address (gRPC listen address' 'default: "127.0.0.1:50051";' \
    '--max_sessions (sessions held at once); default: 64;' \
    '--auth_tokens_file' '--session_store' '--shutdown_grace_seconds'
done
out=$("$server" --helppackage 2>&1)
check "meshgauge-server --helppackage" "$out" "--max_rays" "default: 1024;"
out=$("$server" --version 2>&1); rc=$?
[ "$rc" -eq 0 ] && grep -q "^meshgauge-server [0-9]" <<<"$out" ||
  { echo "FAIL: meshgauge-server --version: rc $rc: $out"; fail=1; }
out=$("$load" --help 2>&1); rc=$?
[ "$rc" -eq 0 ] || { echo "FAIL: meshgauge-load --help exited $rc"; fail=1; }
check "meshgauge-load --help" "$out" "meshgauge-load --target HOST:PORT" \
  '--target (server or balancer); default: "127.0.0.1:50051";' \
  '--clients (concurrent clients, 1..256); default: 4;' '--until_signal'
[ "$fail" -eq 0 ] && echo "flags help: meshgauge-server and meshgauge-load list their flags"
exit "$fail"
