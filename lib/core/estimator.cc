#include "lib/core/estimator.h"

#include <algorithm>
#include <cmath>

namespace meshgauge {

ConeEstimate EstimateCone(absl::Span<const double> t,
                          absl::Span<const ConeRay> cone, double kappa,
                          absl::Span<uint8_t> kept,
                          std::vector<double>& scratch) {
  ConeEstimate est;
  scratch.clear();
  double sum = 0;
  for (double tk : t) {
    if (!std::isnan(tk)) {
      scratch.push_back(tk);
      sum += tk;
    }
  }
  std::fill(kept.begin(), kept.end(), 0);
  const size_t n = scratch.size();
  est.hits = static_cast<int32_t>(n);
  if (n == 0) return est;
  const double mean = sum / static_cast<double>(n);
  double var = 0;
  for (double tk : scratch) var += (tk - mean) * (tk - mean);
  const double sigma = std::sqrt(var / static_cast<double>(n));
  const size_t mid = n / 2;
  std::nth_element(scratch.begin(), scratch.begin() + mid, scratch.end());
  const double upper = scratch[mid];
  const double lower =
      n % 2 == 0 ? *std::max_element(scratch.begin(), scratch.begin() + mid)
                 : upper;
  const double median = (lower + upper) / 2;
  const double tolerance = 1e-12 * std::abs(median);
  const double bound = kappa * sigma + tolerance;
  auto keep = [&](auto&& accept) {
    double num = 0;
    for (size_t k = 0; k < t.size(); ++k) {
      if (std::isnan(t[k]) || !accept(t[k])) continue;
      kept[k] = 1;
      ++est.kept;
      num += cone[k].weight * t[k];
      est.weight_sum += cone[k].weight;
    }
    est.value = num / est.weight_sum;
  };
  keep([&](double tk) { return std::abs(tk - median) <= bound; });
  // SPEC v2 §7, kappa = 0 with an even count whose two middle distances
  // differ: no ray equals the median, so keep the two middle ones.
  if (est.kept == 0) {
    keep([&](double tk) {
      return std::abs(tk - lower) <= tolerance ||
             std::abs(tk - upper) <= tolerance;
    });
  }
  return est;
}

}  // namespace meshgauge
