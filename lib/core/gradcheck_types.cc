#include "lib/core/gradcheck_types.h"

#include <algorithm>
#include <cmath>

namespace meshgauge {

double GradCheckRelativeError(double fd, double analytic, double floor) {
  return std::abs(fd - analytic) /
         std::max({std::abs(analytic), std::abs(fd), floor});
}

double GradCheckFloor(double first_step, double step, double weights_norm) {
  return 1e-2 * (first_step / step) * std::max(1.0, weights_norm);
}

GradCheckVerdict GradCheckReport::Verdict() const {
  const int64_t samples = std::ssize(rows);
  if (passed != clean || vjp_passed != vjp_checks ||
      penalty_passed != penalty_clean) {
    return GradCheckVerdict::kFail;
  }
  if (samples == 0 || clean < min_clean_fraction * samples) {
    return GradCheckVerdict::kInconclusive;
  }
  return GradCheckVerdict::kPass;
}

}  // namespace meshgauge
