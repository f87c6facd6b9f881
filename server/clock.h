// Time source for sessions (injectable for TTL tests): the points in time
// a test must control, such as a session's last use. Durations are
// measured with a Stopwatch (lib/core/stopwatch.h, which states the rule).
#pragma once

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

}  // namespace meshgauge::server
