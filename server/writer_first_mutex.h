// A reader/writer lock under which a waiting writer goes before readers
// that come after it, so that a stream of computations (readers) cannot
// starve a position update (the writer): it waits only for the readers
// already inside. std::shared_mutex (glibc's rwlock) lets new readers in
// while a writer waits: with 32 clients computing, updates waited past
// their 120 s deadlines. Usable with std::shared_lock and std::unique_lock;
// a capability for clang's thread-safety analysis (ABSL_GUARDED_BY).
#pragma once

#include <chrono>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace meshgauge::server {

// The lock and unlock functions are what the analysis trusts, so their
// bodies are not analysed against this capability (as absl::Mutex's own).
class ABSL_LOCKABLE WriterFirstMutex {
 public:
  void lock_shared() ABSL_SHARED_LOCK_FUNCTION() ABSL_NO_THREAD_SAFETY_ANALYSIS {
    absl::MutexLock lock(&mu_, absl::Condition(this, &WriterFirstMutex::ReaderMayEnter));
    ++readers_;
  }
  void unlock_shared() ABSL_UNLOCK_FUNCTION() ABSL_NO_THREAD_SAFETY_ANALYSIS {
    absl::MutexLock lock(&mu_);
    --readers_;
  }
  void lock() ABSL_EXCLUSIVE_LOCK_FUNCTION() ABSL_NO_THREAD_SAFETY_ANALYSIS {
    absl::MutexLock lock(&mu_);
    ++writers_waiting_;
    mu_.Await(absl::Condition(this, &WriterFirstMutex::WriterMayEnter));
    --writers_waiting_;
    writer_ = true;
  }
  // lock() by `deadline`; false, holding nothing, when it passes first
  // (readers held back meanwhile are let in again).
  bool try_lock_until(std::chrono::system_clock::time_point deadline)
      ABSL_EXCLUSIVE_TRYLOCK_FUNCTION(true) ABSL_NO_THREAD_SAFETY_ANALYSIS {
    absl::MutexLock lock(&mu_);
    ++writers_waiting_;
    const bool got = mu_.AwaitWithDeadline(
        absl::Condition(this, &WriterFirstMutex::WriterMayEnter),
        absl::FromChrono(deadline));
    --writers_waiting_;
    if (got) writer_ = true;
    return got;
  }
  // Writers waiting now (for tests and diagnostics).
  int writers_waiting() {
    absl::MutexLock lock(&mu_);
    return writers_waiting_;
  }
  void unlock() ABSL_UNLOCK_FUNCTION() ABSL_NO_THREAD_SAFETY_ANALYSIS {
    absl::MutexLock lock(&mu_);
    writer_ = false;
  }

 private:
  // absl::Mutex evaluates these, holding mu_, whenever mu_ is released.
  bool ReaderMayEnter() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    return !writer_ && writers_waiting_ == 0;
  }
  bool WriterMayEnter() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    return !writer_ && readers_ == 0;
  }

  absl::Mutex mu_;
  int readers_ ABSL_GUARDED_BY(mu_) = 0;
  int writers_waiting_ ABSL_GUARDED_BY(mu_) = 0;
  bool writer_ ABSL_GUARDED_BY(mu_) = false;
};

// Holds a WriterFirstMutex its caller locked exclusively (lock() or a
// successful try_lock_until) until destroyed: the analysis knows it is held
// in between and released on every return.
class ABSL_SCOPED_LOCKABLE AdoptedWriterLock {
 public:
  explicit AdoptedWriterLock(WriterFirstMutex* mu)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu)
      : mu_(mu) {}
  ~AdoptedWriterLock() ABSL_UNLOCK_FUNCTION() { mu_->unlock(); }
  AdoptedWriterLock(const AdoptedWriterLock&) = delete;
  AdoptedWriterLock& operator=(const AdoptedWriterLock&) = delete;

 private:
  WriterFirstMutex* const mu_;
};

}  // namespace meshgauge::server
