// The CONE estimator of SPEC §5 on one vertex's hit distances.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/types/span.h"
#include "lib/core/cone.h"

namespace meshgauge {

struct ConeEstimate {
  double value = 0;       // sum_kept w t / sum_kept w (valid if kept > 0).
  double weight_sum = 0;  // sum_kept w.
  int32_t hits = 0;       // rays with a hit.
  int32_t kept = 0;       // rays that passed the filter.
};

// SelectMiddle's result: the two middle values (equal for an odd count).
struct MiddleValues {
  double lower = 0;
  double upper = 0;
};
// The values of ranks n/2 - 1 and n/2 (0-based, ascending) of the n
// values `v` (no NaN) for an even n, of rank n/2 twice for an odd one; both
// 0 for none. `lo`, `hi`: the least and the greatest of them. Reorders `v`.
// Exact: the values std::nth_element would select.
MiddleValues SelectMiddle(std::vector<double>& v, double lo, double hi);

// t[k]: hit distance of ray k, or NaN for a miss. kappa >= 0. Writes
// kept[k] = 1 for rays kept by the filter |t_k - median| <= kappa sigma
// (sigma: population standard deviation of the hit distances; the median of
// an even count is the mean of the two middle values; the comparison allows
// 1e-12 |median| so equal distances are all kept; if that keeps none, which
// only kappa = 0 with an even count can cause, the rays at the two middle
// distances are kept, SPEC v2 §7). `scratch` is reused
// storage. Deterministic: the result depends only on the inputs.
ConeEstimate EstimateCone(absl::Span<const double> t,
                          absl::Span<const ConeRay> cone, double kappa,
                          absl::Span<uint8_t> kept,
                          std::vector<double>& scratch);

}  // namespace meshgauge
