// A ComputeControl as the workers of one computation see it: its hooks
// called one at a time, progress reported at most once per percent of the
// total (and at the end), as ComputeControl promises its callers.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <mutex>

#include "lib/core/sdf_types.h"

namespace meshgauge {

class ControlGate {
 public:
  // total > 0: the units (samples) the computation reports progress in.
  ControlGate(const ComputeControl& control, int64_t total)
      : control_(control), total_(total) {}
  // Returns false once cancellation was requested.
  bool Poll() {
    if (stop_.load(std::memory_order_relaxed)) return false;
    if (!control_.cancelled) return true;
    std::lock_guard<std::mutex> lock(mu_);
    if (control_.cancelled()) stop_ = true;
    return !stop_;
  }
  // Records n more units done; reports when a percent was crossed or all
  // are done.
  void Done(int64_t n) {
    const int64_t done = done_.fetch_add(n) + n;
    if (!control_.progress) return;
    std::lock_guard<std::mutex> lock(mu_);
    if (done * 100 / total_ > reported_ * 100 / total_ || done == total_) {
      reported_ = std::max(reported_, done);
      control_.progress(reported_, total_);
    }
  }
  bool stopped() const { return stop_; }

 private:
  const ComputeControl& control_;
  const int64_t total_;
  std::mutex mu_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> done_{0};
  int64_t reported_ = 0;
};

}  // namespace meshgauge
