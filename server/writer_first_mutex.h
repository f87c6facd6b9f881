// A reader/writer lock under which a waiting writer goes before readers
// that come after it, so that a stream of computations (readers) cannot
// starve a position update (the writer): it waits only for the readers
// already inside. std::shared_mutex (glibc's rwlock) lets new readers in
// while a writer waits: with 32 clients computing, updates waited past
// their 120 s deadlines. Usable with std::shared_lock and std::unique_lock.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>

namespace meshgauge::server {

class WriterFirstMutex {
 public:
  void lock_shared() {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [this] { return !writer_ && writers_waiting_ == 0; });
    ++readers_;
  }
  void unlock_shared() {
    std::lock_guard<std::mutex> lock(mu_);
    if (--readers_ == 0) cv_.notify_all();
  }
  void lock() {
    std::unique_lock<std::mutex> lock(mu_);
    ++writers_waiting_;
    cv_.wait(lock, [this] { return !writer_ && readers_ == 0; });
    --writers_waiting_;
    writer_ = true;
  }
  // lock() by `deadline`; false, holding nothing, when it passes first
  // (readers held back meanwhile are let in again).
  template <typename Clock, typename Duration>
  bool try_lock_until(std::chrono::time_point<Clock, Duration> deadline) {
    std::unique_lock<std::mutex> lock(mu_);
    ++writers_waiting_;
    const bool got = cv_.wait_until(
        lock, deadline, [this] { return !writer_ && readers_ == 0; });
    --writers_waiting_;
    if (got) {
      writer_ = true;
    } else {
      cv_.notify_all();
    }
    return got;
  }
  // Writers waiting now (for tests and diagnostics).
  int writers_waiting() {
    std::lock_guard<std::mutex> lock(mu_);
    return writers_waiting_;
  }
  void unlock() {
    std::lock_guard<std::mutex> lock(mu_);
    writer_ = false;
    cv_.notify_all();
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  int readers_ = 0;
  int writers_waiting_ = 0;
  bool writer_ = false;
};

}  // namespace meshgauge::server
