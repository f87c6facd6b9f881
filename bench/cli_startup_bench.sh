#!/usr/bin/env bash
# Start-up of the CLI's two programs: milliseconds per `--version` run
# (best of 3 rounds of N runs) of `meshgauge` (local verbs, no gRPC),
# `meshgauge-remote` (every verb, gRPC loaded) and, as this machine's floor
# for starting a process, /bin/true.
# Usage: bench/cli_startup_bench.sh [BUILD_DIR] [N]
set -euo pipefail
build=${1:-build} n=${2:-100}
per_run_ms() {
  local best=1000000000 round start end ms
  for round in 1 2 3; do
    start=$(date +%s%N)
    for ((i = 0; i < n; ++i)); do "$@" >/dev/null; done
    end=$(date +%s%N)
    ms=$(( (end - start) / n / 1000 ))
    ((ms < best)) && best=$ms
  done
  printf '%d.%03d' $((best / 1000)) $((best % 1000))
}
local_ms=$(per_run_ms "$build/client/meshgauge" --version)
remote_ms=$(per_run_ms "$build/client/meshgauge-remote" --version)
true_ms=$(per_run_ms /bin/true)
echo "start-up per run: meshgauge ${local_ms} ms, meshgauge-remote ${remote_ms} ms, /bin/true ${true_ms} ms"
