// A progress bar on stderr for long CLI runs.
#pragma once

#include <cstdint>
#include <string>

#include "lib/core/sdf_types.h"
#include "lib/core/stopwatch.h"

namespace meshgauge::cli {

// --progress: auto draws only when stderr is a terminal and only once the
// run has lasted 0.5 s (short runs print nothing); always draws from the
// start wherever stderr goes (one line, ended by a newline); never draws.
enum class ProgressMode { kAuto, kAlways, kNever };

// Draws "LABEL [#####     ]  42%  ETA 3 s", LABEL naming the work (e.g.
// "tracing 13434500 rays"). Finish() clears the line on a terminal and ends
// it otherwise.
class ProgressBar {
 public:
  ProgressBar(std::string label, ProgressMode mode);
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  ~ProgressBar();
  // Whether this bar draws at all (its mode and stderr).
  bool enabled() const { return enabled_; }
  void Update(int64_t done, int64_t total);
  void Finish();
  // A ComputeControl whose progress updates this bar.
  ComputeControl Control();

 private:
  std::string label_;
  bool enabled_;
  bool terminal_;
  double delay_seconds_;
  bool drawn_ = false;
  int last_percent_ = -1;
  Stopwatch watch_;  // since construction.
};

}  // namespace meshgauge::cli
