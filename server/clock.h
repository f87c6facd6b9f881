// Time source for sessions (injectable for TTL tests).
#pragma once

#include <atomic>
#include <chrono>

namespace meshgauge::server {

class Clock {
 public:
  virtual ~Clock() = default;
  // Seconds on a monotonic scale.
  virtual double NowSeconds() const = 0;
};

class SteadyClock : public Clock {
 public:
  double NowSeconds() const override {
    return std::chrono::duration<double>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
};

// A clock the test moves by hand.
class FakeClock : public Clock {
 public:
  double NowSeconds() const override { return now_.load(); }
  void Advance(double seconds) { now_ = now_.load() + seconds; }

 private:
  std::atomic<double> now_{1000.0};
};

}  // namespace meshgauge::server
