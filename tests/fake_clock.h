// A clock tests move by hand (sessions' TTL and idle times).
#pragma once

#include <atomic>

#include "server/clock.h"

namespace meshgauge::testing {

class FakeClock : public server::Clock {
 public:
  double NowSeconds() const override { return now_.load(); }
  void Advance(double seconds) { now_ = now_.load() + seconds; }

 private:
  std::atomic<double> now_{1000.0};
};

}  // namespace meshgauge::testing
