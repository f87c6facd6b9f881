// Waiting for an event in tests instead of sleeping for a fixed time.
#pragma once

#include <chrono>
#include <thread>

namespace meshgauge::testing {

// Polls `done` every 10 ms until it holds or `seconds` have passed; returns
// its last value (assert on the event itself for a clear message).
template <typename Pred>
bool WaitFor(Pred done, double seconds = 10) {
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace meshgauge::testing
