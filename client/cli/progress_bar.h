// A terminal progress bar on stderr for long CLI runs.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace meshgauge::cli {

// Draws "label [#####     ]  42%" on stderr, only when stderr is a terminal
// and only once the run has lasted longer than `delay` (short runs print
// nothing). Finish() clears the line.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label, std::chrono::milliseconds delay =
                                              std::chrono::milliseconds(500));
  ~ProgressBar();
  void Update(int64_t done, int64_t total);
  void Finish();

 private:
  std::string label_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::milliseconds delay_;
};

}  // namespace meshgauge::cli
