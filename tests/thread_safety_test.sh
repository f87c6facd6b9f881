#!/usr/bin/env bash
# The server's thread-safety annotations are checked (issue 51): clang's
# -Wthread-safety, as scripts/sanitize.sh builds with it, refuses a read of
# state guarded by an absl::Mutex or by a WriterFirstMutex without its
# lock, and accepts it under the lock (shared for a reader).
#   thread_safety_test.sh SOURCE_DIR
set -euo pipefail
src=$1
grep -q -- '-Werror=thread-safety' "$src/scripts/sanitize.sh" ||
  { echo "FAIL: scripts/sanitize.sh does not build with -Werror=thread-safety"; exit 1; }
flags=(-std=c++20 -fsyntax-only -Wthread-safety -Werror=thread-safety -I"$src" -x c++ -)
check() {  # EXPECT(pass|fail) NAME BODY
  local code="#include <shared_mutex>
#include \"absl/synchronization/mutex.h\"
#include \"server/writer_first_mutex.h\"
struct State {
  absl::Mutex mu;
  int count ABSL_GUARDED_BY(mu) = 0;
  meshgauge::server::WriterFirstMutex rw;
  int value ABSL_GUARDED_BY(rw) = 0;
};
int F(State& s) { $3 }"
  if clang++-14 "${flags[@]}" <<<"$code" 2>/tmp/thread_safety_test.$$; then
    got=pass
  else
    got=fail
  fi
  if [ "$got" != "$1" ]; then
    echo "FAIL: $2: expected clang to $1, it did $got"
    cat /tmp/thread_safety_test.$$
    rm -f /tmp/thread_safety_test.$$
    exit 1
  fi
  rm -f /tmp/thread_safety_test.$$
  echo "ok: $2 ($got)"
}
check fail "absl::Mutex state read unlocked" 'return s.count;'
check pass "absl::Mutex state read locked" 'absl::MutexLock l(&s.mu); return s.count;'
check fail "WriterFirstMutex state read unlocked" 'return s.value;'
check pass "WriterFirstMutex state read shared" 's.rw.lock_shared(); int v = s.value; s.rw.unlock_shared(); return v;'
check fail "WriterFirstMutex state written shared" 's.rw.lock_shared(); s.value = 1; s.rw.unlock_shared(); return 0;'
check pass "WriterFirstMutex state written exclusive" 's.rw.lock(); s.value = 1; s.rw.unlock(); return 0;'
