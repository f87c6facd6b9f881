#include "lib/core/normalized_sdf.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace meshgauge {

std::vector<double> NormalizedSdf(const std::vector<double>& values) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (double v : values) {
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  std::vector<double> out(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const double v = values[i];
    if (!std::isfinite(v)) {
      out[i] = v;
    } else if (hi > lo) {
      out[i] = std::log((v - lo) / (hi - lo) * 4 + 1) / std::log(5.0);
    } else {
      out[i] = 0;
    }
  }
  return out;
}

}  // namespace meshgauge
