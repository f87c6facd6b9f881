#include "lib/core/estimator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace meshgauge {

namespace {

// The middle values of n values once std::nth_element has put the value of
// rank n/2 at `at`, selecting among [begin, ...): that value, and for an
// even n the greatest in [begin, at), which holds rank n/2 - 1 (the ranks
// below the selected range lie elsewhere and are all smaller).
MiddleValues MiddleAt(std::vector<double>::iterator begin,
                      std::vector<double>::iterator at, size_t n) {
  const double upper = *at;
  return {n % 2 == 0 ? *std::max_element(begin, at) : upper, upper};
}

}  // namespace

MiddleValues SelectMiddle(std::vector<double>& v, double lo, double hi) {
  const size_t n = v.size();
  const size_t mid = n / 2;
  if (n == 0) return {};
  if (!(lo < hi)) return {lo, lo};
  // Rank `mid` (and `mid - 1` for an even count) by buckets first: the
  // bucket of x is monotone in x, so the middle ranks lie in the buckets
  // that hold them, and only those buckets' values are selected among.
  constexpr int kBuckets = 64;
  const double scale = kBuckets / (hi - lo);
  if (!std::isfinite(scale) || !(scale > 0)) {  // a tiny or huge range
    std::nth_element(v.begin(), v.begin() + mid, v.end());
    return MiddleAt(v.begin(), v.begin() + mid, n);
  }
  // Clamped before the conversion: a value outside [lo, hi] (a caller's
  // error) cannot index outside the counts.
  auto bucket = [&](double x) {
    return static_cast<int>(std::clamp((x - lo) * scale, 0.0, kBuckets - 1.0));
  };
  size_t count[kBuckets] = {};
  for (double x : v) ++count[bucket(x)];
  const size_t low_rank = n % 2 == 0 ? mid - 1 : mid;
  // The buckets of ranks low_rank and mid, and how many values lie below
  // the first.
  int first = 0;
  size_t below = 0;
  while (below + count[first] <= low_rank) below += count[first++];
  int last = first;
  size_t through = below + count[first];
  while (through <= mid) through += count[++last];
  const auto middle = std::partition(v.begin(), v.end(), [&](double x) {
    const int b = bucket(x);
    return b >= first && b <= last;
  });
  const auto at = v.begin() + static_cast<ptrdiff_t>(mid - below);
  std::nth_element(v.begin(), at, middle);
  return MiddleAt(v.begin(), at, n);
}

ConeEstimate EstimateCone(absl::Span<const double> t,
                          absl::Span<const ConeRay> cone, double kappa,
                          absl::Span<uint8_t> kept,
                          std::vector<double>& scratch) {
  ConeEstimate est;
  scratch.resize(t.size());
  double sum = 0;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  size_t n = 0;
  for (double tk : t) {
    if (std::isnan(tk)) continue;
    scratch[n++] = tk;
    sum += tk;
    lo = std::min(lo, tk);
    hi = std::max(hi, tk);
  }
  scratch.resize(n);
  std::fill(kept.begin(), kept.end(), 0);
  est.hits = static_cast<int32_t>(n);
  if (n == 0) return est;
  const double mean = sum / static_cast<double>(n);
  double var = 0;
  for (double tk : scratch) var += (tk - mean) * (tk - mean);
  const double sigma = std::sqrt(var / static_cast<double>(n));
  // Named, not bound: clang 14 cannot capture a structured binding.
  const MiddleValues middle = SelectMiddle(scratch, lo, hi);
  const double lower = middle.lower;
  const double upper = middle.upper;
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
