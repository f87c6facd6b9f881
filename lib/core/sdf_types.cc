#include "lib/core/sdf_types.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "absl/strings/str_cat.h"

namespace meshgauge {

absl::Status ValidateParams(const SdfParams& p) {
  if (!(p.cone_angle_degrees > 0 && p.cone_angle_degrees < 180)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "cone angle must be in (0, 180) degrees, got ", p.cone_angle_degrees));
  }
  if (p.rays < 0 || p.rays > 4096) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ray count must be in [1, 4096] (0 for the default), got ", p.rays));
  }
  if (!(p.min_weight_angle >= 0) || !std::isfinite(p.min_weight_angle)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "minimum weight angle must be >= 0 radians, got ", p.min_weight_angle));
  }
  if (!(p.kappa >= 0) || !std::isfinite(p.kappa)) {
    return absl::InvalidArgumentError(
        absl::StrCat("kappa must be a finite number >= 0, got ", p.kappa));
  }
  if (!(p.self_hit_epsilon >= 0) || !std::isfinite(p.self_hit_epsilon)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "self-hit epsilon must be >= 0, got ", p.self_hit_epsilon));
  }
  if (!(p.max_distance >= 0) || !std::isfinite(p.max_distance)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "max distance must be >= 0 (0 = bounding-box diagonal), got ",
        p.max_distance));
  }
  if (!(p.contact_angle_degrees > 0 && p.contact_angle_degrees < 90)) {
    return absl::InvalidArgumentError(
        absl::StrCat("contact angle must be in (0, 90) degrees, got ",
                     p.contact_angle_degrees));
  }
  return absl::OkStatus();
}

absl::Status ValidateControl(const ComputeControl& control) {
  if (control.threads < 0 || control.threads > 1024) {
    return absl::InvalidArgumentError(absl::StrCat(
        "threads must be in [0, 1024] (0 = all cores), got ", control.threads));
  }
  return absl::OkStatus();
}

ResolvedParams ResolveParams(const SdfParams& params, int dimension) {
  ResolvedParams r;
  r.params = params;
  r.aperture_radians = params.cone_angle_degrees * std::numbers::pi / 180;
  if (params.method != SdfMethod::kCone) {
    r.rays = 1;
  } else {
    r.rays = params.rays > 0 ? params.rays : (dimension == 2 ? 32 : 100);
  }
  r.contact_cosine =
      std::cos(params.contact_angle_degrees * std::numbers::pi / 180);
  r.min_weight_angle = params.min_weight_angle > 0
                           ? params.min_weight_angle
                           : r.aperture_radians / (2.0 * r.rays);
  return r;
}

const char* SampleSetName(SampleSet set) {
  return set == SampleSet::kFaces ? "faces" : "vertices";
}

const char* SampleName(SampleSet set) {
  return set == SampleSet::kFaces ? "face" : "vertex";
}

const char* VertexStatusName(VertexStatus status) {
  switch (status) {
    case VertexStatus::kOk:
      return "OK";
    case VertexStatus::kNoHit:
      return "NO_HIT";
    case VertexStatus::kNoFaces:
      return "NO_FACES";
    case VertexStatus::kDegenerateNormal:
      return "DEGENERATE_NORMAL";
  }
  return "UNKNOWN";
}

ValueStats SummarizeValues(const std::vector<double>& values) {
  std::vector<double> ok;
  double sum = 0;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    ok.push_back(v);
    sum += v;
  }
  ValueStats s;
  s.count = std::ssize(ok);
  if (ok.empty()) {
    s.min = s.max = s.mean = s.median =
        std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  const auto [min, max] = std::minmax_element(ok.begin(), ok.end());
  s.min = *min;
  s.max = *max;
  s.mean = sum / static_cast<double>(ok.size());
  // The median by selection (linear time): the upper middle element, and
  // for an even count the largest of the lower half too.
  const auto upper = ok.begin() + std::ssize(ok) / 2;
  std::nth_element(ok.begin(), upper, ok.end());
  s.median = ok.size() % 2
                 ? *upper
                 : (*std::max_element(ok.begin(), upper) + *upper) / 2;
  return s;
}

int64_t SdfResult::CountStatus(VertexStatus s) const {
  return std::count(status.begin(), status.end(), s);
}

}  // namespace meshgauge
