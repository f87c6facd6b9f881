#!/usr/bin/env bash
# --help of the benchmarks lists their own flags (server/flags_help.h): absl
# printed "No flags matched." and exited 1, since they define their flags in
# files not named after the program.
# Usage: bench_help_test.sh PROGRAM EXPECTED_FLAG...
set -uo pipefail
prog=$1; shift
out=$("$prog" --help 2>&1); rc=$?
fail=0
[ "$rc" -eq 0 ] || { echo "FAIL: $prog --help exited $rc"; fail=1; }
if grep -qF "No flags matched" <<<"$out"; then
  echo "FAIL: $prog --help: 'No flags matched.'"; fail=1; fi
for want in "$@"; do
  grep -qF -- "--$want (" <<<"$out" || { echo "FAIL: $prog --help lacks --$want"; fail=1; }
done
[ "$fail" -eq 0 ] && echo "$(basename "$prog") --help lists: $*" || echo "$out" | head -20
exit "$fail"
