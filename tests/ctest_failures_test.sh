#!/usr/bin/env bash
# scripts/ctest_failures.sh with a fake `ctest` on PATH that writes a
# LastTest.log in CTest's layout: a failed GoogleTest case, a failed script
# and a passed test. The script must name both failures with their error
# lines and the output before GoogleTest's footer (not the footer), leave the
# passed test out, and exit with CTest's code; print nothing after a passing
# run; and ignore a log older than the run (another run's).
# Usage: ctest_failures_test.sh SCRIPT
set -euo pipefail
script=$(realpath "${1:?usage: ctest_failures_test.sh SCRIPT}")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

mkdir -p "$tmp/bin" "$tmp/build/Testing/Temporary"
cat >"$tmp/fixture.log" <<'EOF'
Start testing: Dec 06 18:15 UTC
----------------------------------------------------------
1/3 Testing: Suite.Passes
1/3 Test: Suite.Passes
Command: "/build/tests/lib_tests" "--gtest_filter=Suite.Passes"
Directory: /build/tests
"Suite.Passes" start time: Dec 06 18:15 UTC
Output:
----------------------------------------------------------
[ RUN      ] Suite.Passes
a line of a passing test
[       OK ] Suite.Passes (1 ms)
<end of output>
Test time =   0.01 sec
----------------------------------------------------------
Test Passed.
"Suite.Passes" end time: Dec 06 18:15 UTC
----------------------------------------------------------

2/3 Testing: Suite.Breaks
2/3 Test: Suite.Breaks
Command: "/build/tests/lib_tests" "--gtest_filter=Suite.Breaks"
Directory: /build/tests
"Suite.Breaks" start time: Dec 06 18:15 UTC
Output:
----------------------------------------------------------
[ RUN      ] Suite.Breaks
tests/suite_test.cc:42: Failure
Expected equality of these values:
  values[7]
    Which is: 0.5
  0.25
[  FAILED  ] Suite.Breaks (3 ms)
[----------] 1 test from Suite (3 ms total)

[----------] Global test environment tear-down
[==========] 1 test from 1 test suite ran. (3 ms total)
[  FAILED  ] 1 test, listed below:
<end of output>
Test time =   0.02 sec
----------------------------------------------------------
Test Failed.
"Suite.Breaks" end time: Dec 06 18:15 UTC
----------------------------------------------------------

3/3 Testing: balancer
3/3 Test: balancer
Command: "/src/tests/balancer_test.sh"
Directory: /build/tests
"balancer" start time: Dec 06 18:15 UTC
Output:
----------------------------------------------------------
phase drain: 0 failed calls
FAIL: fan-out: 3 range calls in the log, expected 4
<end of output>
Test time =  40.00 sec
----------------------------------------------------------
Test Fail Reason:
Required regular expression not found.
"balancer" end time: Dec 06 18:15 UTC
----------------------------------------------------------

End testing: Dec 06 18:16 UTC
EOF
# The fake ctest: records its arguments, writes the fixture as this run's
# log (unless told not to; dated a few seconds ahead, so that it is newer
# than the script's start on any file system's clock) and exits with the
# code it is given.
cat >"$tmp/bin/ctest" <<EOF
#!/usr/bin/env bash
echo "\$*" >"$tmp/ctest_args"
if [[ \${FAKE_WRITE_LOG:-1} == 1 ]]; then
  cp "$tmp/fixture.log" Testing/Temporary/LastTest.log
  touch -d "@\$(( \$(date +%s) + 3 ))" Testing/Temporary/LastTest.log
fi
exit \${FAKE_CTEST_CODE:-8}
EOF
chmod +x "$tmp/bin/ctest"
run() {
  (cd "$tmp/build" && PATH="$tmp/bin:$PATH" "$script" -j2 >"$tmp/out" 2>&1)
}

# A failing run: both failures explained, the passing test not.
set +e
run
code=$?
set -e
cat "$tmp/out"
[[ $code == 8 ]] || fail "exit code $code, expected CTest's 8"
[[ $(cat "$tmp/ctest_args") == "-j2" ]] ||
  fail "ctest got '$(cat "$tmp/ctest_args")', not the script's arguments"
out=$(cat "$tmp/out")
[[ $out == *"== why the failed tests failed"* ]] || fail "no heading"
[[ $out == *"-- Suite.Breaks"* ]] || fail "Suite.Breaks not named"
[[ $out == *"   ! tests/suite_test.cc:42: Failure"* ]] ||
  fail "the GoogleTest failure's location is not an error line"
[[ $out == *"    Which is: 0.5"* ]] || fail "the failure's output is missing"
[[ $out != *"Global test environment tear-down"* ]] ||
  fail "GoogleTest's footer was printed"
[[ $out == *"-- balancer"* ]] || fail "balancer not named"
[[ $out == *"   ! FAIL: fan-out: 3 range calls"* ]] ||
  fail "the script's FAIL line is not an error line"
[[ $out != *"Suite.Passes"* && $out != *"a line of a passing test"* ]] ||
  fail "the passing test was printed"

# A passing run prints nothing of its own and exits 0.
FAKE_CTEST_CODE=0 run || fail "a passing run exited non-zero"
[[ ! -s $tmp/out ]] || fail "a passing run printed: $(cat "$tmp/out")"

# A failing run that wrote no log leaves the older one alone.
touch -d '-2 minutes' "$tmp/build/Testing/Temporary/LastTest.log"
set +e
FAKE_WRITE_LOG=0 run
code=$?
set -e
[[ $code == 8 ]] || fail "exit code $code with a stale log, expected 8"
[[ ! -s $tmp/out ]] || fail "a stale log was read: $(cat "$tmp/out")"
echo "ctest_failures: failures explained, passes and stale logs left alone"
