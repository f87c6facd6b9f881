#!/usr/bin/env bash
# Runs CTest with the arguments given; when a test fails, prints after
# CTest's summary why, from Testing/Temporary/LastTest.log: per failed test
# its error lines (a GoogleTest failure's location, a sanitizer's report
# line, a script's FAIL) and the last lines of its output before
# GoogleTest's footer or a sanitizer's shadow-byte dump, so that a log read
# from its end (a CI excerpt) names the cause, not only the test. Run from a
# build directory; exits with CTest's code.
#   scripts/ctest_failures.sh [ctest args...]
set -uo pipefail
log=Testing/Temporary/LastTest.log
marker=$(mktemp)
trap 'rm -f "$marker"' EXIT
rc=0
ctest "$@" || rc=$?
[ "$rc" -eq 0 ] && exit 0
# A log older than this run is another run's.
[ "$log" -nt "$marker" ] || exit "$rc"
awk -v keep=12 -v errors=6 '
  inside && /^<end of output>$/ { inside = 0; next }
  inside {
    if ($0 ~ /^\[----------\] Global test environment tear-down/ ||
        $0 ~ /^Shadow bytes around the buggy address:/) cut = 1
    if (!cut) line[n++] = $0
    if (e < errors && $0 ~ /: Failure$|runtime error:|==[0-9]+==ERROR|^SUMMARY: |^FAIL/) err[e++] = $0
    next
  }
  /^[0-9]+\/[0-9]+ Test: / { name = $NF; next }
  /^Output:$/ { expect = 1; n = 0; e = 0; cut = 0; next }
  expect && /^-+$/ { expect = 0; inside = 1; next }
  /^Test Fail(ed\.| Reason:)/ && name != "" {
    if (!shown++) print "== why the failed tests failed (their output)"
    print "-- " name
    for (i = 0; i < e; i++) print "   ! " err[i]
    for (i = (n > keep ? n - keep : 0); i < n; i++) print "   " line[i]
    name = ""
  }' "$log"
exit "$rc"
