#include "client/cli/progress_bar.h"

#include <unistd.h>

#include <cstdio>

namespace meshgauge::cli {

ProgressBar::ProgressBar(std::string label, ProgressMode mode)
    : label_(std::move(label)),
      enabled_(mode == ProgressMode::kAlways ||
               (mode == ProgressMode::kAuto && isatty(STDERR_FILENO) == 1)),
      terminal_(isatty(STDERR_FILENO) == 1),
      delay_seconds_(mode == ProgressMode::kAuto ? 0.5 : 0) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(int64_t done, int64_t total) {
  if (!enabled_ || total <= 0) return;
  const double seconds = watch_.Seconds();
  if (!drawn_ && seconds < delay_seconds_) return;
  const int percent = static_cast<int>(100 * done / total);
  if (percent == last_percent_) return;
  last_percent_ = percent;
  constexpr int kWidth = 40;
  std::string bar(static_cast<size_t>(kWidth * done / total), '#');
  bar.resize(kWidth, ' ');
  std::string eta;
  if (done > 0 && done < total && seconds > 0.5) {
    eta = "  ETA " +
          std::to_string(
              static_cast<int64_t>(seconds * (total - done) / done + 0.5)) +
          " s";
  }
  std::fprintf(stderr, "\r%s [%s] %3d%%%s%s", label_.c_str(), bar.c_str(),
               percent, eta.c_str(), terminal_ ? "\033[K" : "");
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::Finish() {
  if (!drawn_) return;
  std::fputs(terminal_ ? "\r\033[K" : "\n", stderr);
  std::fflush(stderr);
  drawn_ = false;
}

ComputeControl ProgressBar::Control() {
  ComputeControl control;
  control.progress = [this](int64_t done, int64_t total) {
    Update(done, total);
  };
  return control;
}

}  // namespace meshgauge::cli
