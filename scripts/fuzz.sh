#!/usr/bin/env bash
# Fuzzes each mesh reader with libFuzzer (clang-14, ASan + UBSan) for
# SECONDS each (default 60; one reader per core at a time), starting from
# the committed seed corpus tests/fuzz/corpus/FORMAT. Exits non-zero on any
# finding (crash, sanitizer report, leak, timeout, out-of-memory); the
# reproducer is left in build-fuzz/. Prints the executions run per reader.
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH="${1:-60}"
scripts/install_deps.sh
OUT=build-fuzz
mkdir -p "$OUT/obj"
CXX=clang++-14
FLAGS=(-std=c++20 -O1 -g -I. -fsanitize=fuzzer-no-link,address,undefined
       -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
read -r -a LIBS <<<"$(pkg-config --libs absl_strings absl_status absl_statusor \
  absl_str_format absl_hash absl_raw_hash_set tbb)"
SOURCES=(lib/io/mesh_builder.cc lib/io/mesh_io.cc lib/io/obj_reader.cc
         lib/io/off_reader.cc lib/io/ply_header.cc lib/io/ply_reader.cc
         lib/io/ply_triangles.cc lib/io/scan.cc
         lib/io/stl_reader.cc lib/core/polygon.cc lib/core/mesh.cc
         lib/core/components.cc lib/core/mesh_repair.cc
         lib/core/nesting.cc lib/core/weld.cc lib/core/missing_values.cc
         lib/core/integrals.cc)
# Objects and fuzzers are built, and the readers fuzzed, JOBS at a time
# (one per core: each fuzzer is one process on one core, for SECONDS_EACH).
JOBS="$(nproc)"
pids=()
drain() {  # waits for the background jobs in pids; fails when one did
  local pid failed=0
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  pids=()
  return "$failed"
}
throttle() {  # waits for the oldest job once JOBS of them run
  if [ "${#pids[@]}" -ge "$JOBS" ]; then
    local first=${pids[0]}
    pids=("${pids[@]:1}")
    wait "$first"
  fi
}
OBJECTS=()
for src in "${SOURCES[@]}"; do
  obj="$OUT/obj/$(echo "$src" | tr / _).o"
  # Rebuilt when its source or any header of lib/ is newer (a header that
  # changes what it declares would otherwise leave a stale object).
  if [ ! -f "$obj" ] || [ "$src" -nt "$obj" ] ||
     [ -n "$(find lib -name '*.h' -newer "$obj" -print -quit)" ]; then
    throttle
    "$CXX" "${FLAGS[@]}" -c "$src" -o "$obj" &
    pids+=($!)
  fi
  OBJECTS+=("$obj")
done
drain
FORMATS=(obj off ply stl)
for fmt in "${FORMATS[@]}"; do
  throttle
  "$CXX" "${FLAGS[@]}" -fsanitize=fuzzer "-DMESHGAUGE_FUZZ_FORMAT=\".$fmt\"" \
    tests/fuzz/fuzz_reader.cc "${OBJECTS[@]}" "${LIBS[@]}" -o "$OUT/fuzz_$fmt" &
  pids+=($!)
done
drain
fuzz() {  # FORMAT: fuzzes one reader, its output in $OUT/fuzz_FORMAT.log
  local fmt=$1
  mkdir -p "$OUT/corpus_$fmt"
  (cd "$OUT" && "./fuzz_$fmt" -max_total_time="$SECONDS_EACH" \
     -timeout=10 -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
     "corpus_$fmt" "../tests/fuzz/corpus/$fmt") >"$OUT/fuzz_$fmt.log" 2>&1
}
declare -A fuzz_rc
for ((i = 0; i < ${#FORMATS[@]}; i += JOBS)); do
  batch=("${FORMATS[@]:i:JOBS}")
  for fmt in "${batch[@]}"; do
    fuzz "$fmt" &
    pids+=($!)
  done
  for j in "${!batch[@]}"; do
    rc=0
    wait "${pids[$j]}" || rc=$?
    fuzz_rc[${batch[$j]}]=$rc
  done
  pids=()
done
status=0
for fmt in "${FORMATS[@]}"; do
  log="$OUT/fuzz_$fmt.log"
  if [ "${fuzz_rc[$fmt]}" -eq 0 ]; then
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    echo "fuzz $fmt: ${SECONDS_EACH} s, $execs executions, no findings"
  else
    echo "fuzz $fmt: FINDING (see $log and the crash-*/leak-*/timeout-* file in $OUT)"
    tail -n 40 "$log"
    status=1
  fi
done
exit "$status"
