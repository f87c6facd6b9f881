#include "lib/embree/calibration.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"

namespace meshgauge {
namespace {

std::vector<int64_t> Bin(const std::vector<double>& v, double lo, double hi,
                         int bins) {
  std::vector<int64_t> counts(bins, 0);
  for (double x : v) {
    if (!std::isfinite(x)) continue;
    int b = hi > lo ? static_cast<int>((x - lo) / (hi - lo) * bins) : 0;
    counts[std::clamp(b, 0, bins - 1)]++;
  }
  return counts;
}

// Counts `value` as lower than, equal to (within tolerance * t) or higher
// than the thickness t.
void Tally(double value, double t, double tolerance, int64_t* lower,
           int64_t* equal, int64_t* higher) {
  if (std::abs(value - t) <= tolerance * t) {
    ++*equal;
  } else if (value < t) {
    ++*lower;
  } else {
    ++*higher;
  }
}

}  // namespace

absl::StatusOr<CalibrationReport> Calibrate(const SdfEvaluator& evaluator,
                                            const CalibrationParams& params,
                                            const ComputeControl& control) {
  if (!(params.t_min > 0) || !std::isfinite(params.t_min)) {
    return absl::InvalidArgumentError(
        absl::StrCat("t_min must be a finite number > 0, got ", params.t_min));
  }
  if (!(params.equal_tolerance >= 0) ||
      !std::isfinite(params.equal_tolerance)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "equal tolerance must be >= 0, got ", params.equal_tolerance));
  }
  if (params.sdf.samples != SampleSet::kVertices) {
    return absl::InvalidArgumentError(
        "calibration compares vertex values: use vertex samples, not face "
        "samples");
  }
  if (params.bins < 1 || params.bins > 1000) {
    return absl::InvalidArgumentError(
        absl::StrCat("bins must be in [1, 1000], got ", params.bins));
  }
  SdfParams cone = params.sdf;
  cone.method = SdfMethod::kCone;
  SdfParams normal = params.sdf;
  normal.method = SdfMethod::kNormalRay;
  auto sdf = evaluator.Compute(cone, control);
  if (!sdf.ok()) return sdf.status();
  auto thick = evaluator.Compute(normal, control);
  if (!thick.ok()) return thick.status();
  SdfParams sphere = params.sdf;
  sphere.method = SdfMethod::kSphere;
  auto ball = evaluator.Compute(sphere, control);
  if (!ball.ok()) return ball.status();
  CalibrationReport rep;
  rep.sdf = std::move(sdf->values);
  rep.thickness = std::move(thick->values);
  rep.ball = std::move(ball->values);
  double max_t = 0, min_sdf = std::numeric_limits<double>::infinity();
  double min_ball = min_sdf;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (size_t i = 0; i < rep.sdf.size(); ++i) {
    const double s = rep.sdf[i], t = rep.thickness[i], b = rep.ball[i];
    for (double v : {s, t, b}) {
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
    if (!std::isfinite(t)) continue;
    if (std::isfinite(b)) {
      ++rep.ball_compared;
      min_ball = std::min(min_ball, b);
      Tally(b, t, params.equal_tolerance, &rep.ball_lower, &rep.ball_equal,
            &rep.ball_higher);
    }
    if (!std::isfinite(s)) continue;
    ++rep.compared;
    max_t = std::max(max_t, t);
    min_sdf = std::min(min_sdf, s);
    Tally(s, t, params.equal_tolerance, &rep.lower, &rep.equal, &rep.higher);
  }
  if (rep.compared == 0) {
    return absl::FailedPreconditionError(
        "no vertex has both an SDF and a thickness value (is the mesh open "
        "or inward oriented?)");
  }
  rep.alpha1 = max_t / params.t_min;
  rep.alpha2 = min_sdf / params.t_min;
  rep.ball_alpha = rep.ball_compared > 0
                       ? min_ball / params.t_min
                       : std::numeric_limits<double>::quiet_NaN();
  rep.sdf_histogram = {lo, hi, Bin(rep.sdf, lo, hi, params.bins)};
  rep.thickness_histogram = {lo, hi, Bin(rep.thickness, lo, hi, params.bins)};
  rep.ball_histogram = {lo, hi, Bin(rep.ball, lo, hi, params.bins)};
  return rep;
}

}  // namespace meshgauge
