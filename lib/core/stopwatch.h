// Wall-clock time of a stage, for the timings that results and summaries
// report (steady clock, seconds).
//
// The one way to time in lib/, server/, client/ and bench/: a duration (a
// stage's, a call's, a throttle's) is a Stopwatch. The other clocks have
// other jobs: server/clock.h's injected Clock is for times a test must
// control (sessions' idle time and expiry; tests give a FakeClock), and
// std::chrono::system_clock only gives dates (the process start time in
// the metrics) and makes and checks gRPC deadlines (gRPC's type). Nothing
// else reads std::chrono::steady_clock (but server::SteadyClock, the
// Clock's real source) or absl::Now.
#pragma once

#include <chrono>

namespace meshgauge {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  // Seconds since construction or the last Restart().
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                         start_)
        .count();
  }
  void Restart() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace meshgauge
