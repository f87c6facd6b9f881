#!/usr/bin/env bash
# Runs CTest with the arguments given; when a test fails, prints after
# CTest's summary the last lines of each failed test's output (from
# Testing/Temporary/LastTest.log), so a log read from its end (a CI
# excerpt) names why, not only which. Run from a build directory.
#   scripts/ctest_failures.sh [ctest args...]
set -uo pipefail
rc=0
ctest "$@" || rc=$?
[ "$rc" -eq 0 ] && exit 0
log=Testing/Temporary/LastTest.log
[ -f "$log" ] || exit "$rc"
echo "== the failed tests' last lines of output"
awk -v keep=12 '
  / Test: / { name = $NF }
  /^Output:$/ { n = 0; inside = 0; next }
  /^-+$/ && n == 0 && !inside { inside = 1; next }
  /^<end of output>$/ { inside = 0; next }
  inside { line[n++] = $0 }
  /^Test Failed/ {
    print "-- " name
    for (i = (n > keep ? n - keep : 0); i < n; i++) print "   " line[i]
  }' "$log"
exit "$rc"
